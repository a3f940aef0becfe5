#pragma once
// Pose-conditioned Invertible Network (PIN, INS section 3.2, eq. 13-15): a
// chain of 2D and 1D coupling layers (coupling_layer.h) sharing one pose
// embedding per frame,
//   PIN(x, p)    = C_L(... C_2(C_1(x, z_p), z_p) ..., z_p)          (eq. 13)
//   PIN^-1(y, p) = C_1^-1(... C_L^-1(y, z_p) ..., z_p)              (eq. 14)
// with z_p = PoseEncoder(bones) (eq. 7). Batched over frames and points,
// differentiable in the points, the pose embedding and all parameters;
// det(dPIN/dx) = 1 (Appendix C.2). Identity at initialisation (Appendix C.1)
// and, for any parameters, at the zero relative pose (identity bones).
//
// Split schedule (the paper does not give one): layer k uses pattern k mod 6 of
//   2D (x, y | z), 1D (z | x, y), 2D (y, z | x), 1D (x | y, z), 2D (z, x | y), 1D (y | z, x)
// i.e. every 2D layer is followed by a 1D layer on the axis it kept, so every
// pair of layers moves all three coordinates, and the default 18 layers are
// three full cycles: 9 rotations (3 per plane), 9 translations (3 per axis).
#include <torch/torch.h>

#include <memory>
#include <vector>

#include "fskin/invertible/coupling_layer.h"
#include "fskin/invertible/pose_encoding.h"

namespace fskin {

// The moved axes of each layer (size 2: a 2D layer, size 1: a 1D layer).
std::vector<std::vector<int64_t>> pin_split_schedule(int64_t num_layers);

struct PinOptions {
  int64_t num_layers = 18;  // Table 4, row 2
  CouplingLayerOptions coupling;
  PoseEncoderOptions pose;
  // false: the PIN has no pose encoder and is driven by pose embeddings the
  // caller computes (*_embedded), e.g. one encoder shared by INS's two PINs:
  // the paper's parameter table counts one 0.46M bone encoder next to two
  // 0.41M PINs (Table 4, rows 1, 3, 6).
  bool own_pose_encoder = true;
  // Throws fskin::Error naming the bad field (also when the pose embedding
  // width differs from coupling.embedding_dim).
  void validate() const;
};

class PinImpl : public torch::nn::Module {
 public:
  explicit PinImpl(const PinOptions& options = {});

  // bones [B, J, 4, 4] (relative, canonical -> posed) -> z_p [B, E]. Needs own_pose_encoder.
  torch::Tensor encode_pose(const torch::Tensor& bones);
  // x [B, N, 3] and the frames' bones [B, J, 4, 4] -> [B, N, 3]. Needs own_pose_encoder.
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& bones);
  torch::Tensor inverse(const torch::Tensor& y, const torch::Tensor& bones);
  // The same with the pose embedding z_p [B, E] given, e.g. computed once per
  // frame and reused for many point batches.
  torch::Tensor forward_embedded(const torch::Tensor& x, const torch::Tensor& pose_embedding);
  torch::Tensor inverse_embedded(const torch::Tensor& y, const torch::Tensor& pose_embedding);

  const std::vector<std::shared_ptr<CouplingLayer>>& layers() const { return layers_; }
  const PinOptions& options() const { return options_; }

 private:
  void check_frames(const torch::Tensor& points, const torch::Tensor& bones) const;
  void check_inputs(const torch::Tensor& points, const torch::Tensor& pose_embedding) const;

  PinOptions options_;
  PoseEncoder pose_encoder_{nullptr};
  std::vector<std::shared_ptr<CouplingLayer>> layers_;
};
TORCH_MODULE(Pin);

}  // namespace fskin
