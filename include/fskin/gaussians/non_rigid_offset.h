#pragma once
// A pose-conditioned non-rigid offset of the canonical Gaussians
// (3DGS-Avatar, Qian et al. 2024, sec. 3.2, its position part): clothing and
// flesh that move with the pose in ways the skinning does not,
//   delta(x, pose) = size * MLP(gamma(x) ; pose features),
// added to a Gaussian's canonical mean before skinning. gamma is NeRF's
// frequency encoding of x in the canonical box (networks/frequency_encoding.h);
// the pose features are every bone's rotation relative to the root bone's,
// R_0^T R_j - I (j >= 1, flattened): any skeleton, and a rigid motion of the
// whole body leaves them unchanged. The pose enters the first layer as a bias
// computed once per frame, so a Gaussian costs what the position MLP costs.
// The last layer starts at zero: the offset starts at zero.
#include <torch/torch.h>

#include <cstdint>

namespace fskin {

struct NonRigidOffsetOptions {
  int64_t frequencies = 4;  // of the position encoding
  int64_t hidden = 64;      // width of the two hidden ReLU layers
};

class NonRigidOffsetImpl : public torch::nn::Module {
 public:
  // joints: the skeleton's; box_low / box_high: the canonical box the
  // positions are encoded in (outside it the encoding still applies); size:
  // the unit of the output (the character's size).
  NonRigidOffsetImpl(int64_t joints, const torch::Tensor& box_low, const torch::Tensor& box_high, double size,
                     const NonRigidOffsetOptions& options);
  // canonical means [N, 3], bones [J, 4, 4] (canonical -> posed) -> offsets [N, 3].
  torch::Tensor forward(const torch::Tensor& means, const torch::Tensor& bones);

 private:
  NonRigidOffsetOptions options_;
  int64_t joints_;
  double size_;
  torch::Tensor box_low_, box_high_;  // buffers
  torch::nn::Linear position_{nullptr}, pose_{nullptr}, hidden_{nullptr}, out_{nullptr};
};
TORCH_MODULE(NonRigidOffset);

}  // namespace fskin
