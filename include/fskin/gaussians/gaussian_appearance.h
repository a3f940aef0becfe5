#pragma once
// The Gaussian avatar's response to a per-frame appearance code (the volume
// avatar's appearance codes, radiance/appearance_codes.h, NeRF in the Wild's
// embeddings): what a frame's light or exposure does to the body that the
// Gaussians' own colours, shared by every frame, cannot hold.
//   colour'(x, frame) = colour(x) + MLP(gamma(x) ; code_frame),
// added before shading (gaussian_shading.h), so that with irradiance shading
// the code changes the albedo. gamma is NeRF's frequency encoding of the
// canonical mean in the canonical box (networks/frequency_encoding.h), so a
// code may darken one part and not another. The code enters the first layer
// as a bias computed once per frame, as the non-rigid offset's pose does
// (non_rigid_offset.h): a Gaussian costs what the position MLP costs. The
// last layer starts at zero, and the trainer keeps the codes at zero mean
// over the frames: code zero, which poses never trained get, is the frames'
// average appearance.
#include <torch/torch.h>

#include <cstdint>

namespace fskin {

struct GaussianAppearanceOptions {
  int64_t dim = 0;          // the code length; 0: no appearance codes
  int64_t hidden = 32;      // width of the hidden ReLU layer
  int64_t frequencies = 4;  // of the position encoding
  void validate() const;
};

class GaussianAppearanceImpl : public torch::nn::Module {
 public:
  // box_low / box_high: the canonical box the means are encoded in.
  GaussianAppearanceImpl(const torch::Tensor& box_low, const torch::Tensor& box_high,
                         const GaussianAppearanceOptions& options);
  // canonical means [N, 3], code [dim] (undefined: code zero) -> colour offsets [N, 3].
  torch::Tensor forward(const torch::Tensor& means, const torch::Tensor& code);
  int64_t dim() const { return options_.dim; }

 private:
  GaussianAppearanceOptions options_;
  torch::Tensor box_low_, box_high_;  // buffers
  torch::nn::Linear position_{nullptr}, code_{nullptr}, out_{nullptr};
};
TORCH_MODULE(GaussianAppearance);

}  // namespace fskin
