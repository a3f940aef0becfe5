#pragma once
// The canonical radiance field of an avatar (Fast-SNARF sec. 7, eq. 18-19;
// InstantAvatar): the multi-resolution hash encoding (ops/hash_encoding.h) of
// the canonical point, normalised into the unit cube of the canonical box,
// followed by a small ReLU MLP (networks/relu_mlp.h) to density sigma >= 0 (per metre) and colour in
// [0, 1]. Colour does not depend on the view direction.
//
// Shading (fskin's addition, not in the papers): with shading "none" the
// colour is one albedo per canonical point (the avatar under unchanging
// light). With "lambert" the MLP also gives a normal-like vector n at the
// canonical point, and a posed sample's colour is
//   albedo x (a + max(0, (R n) . d)),
// R the sample's blended bone rotation (LBS applied to n, as to a normal), d
// a learned light (direction x strength) and a a learned ambient term: a
// diffuse surface under one distant light fixed in the world, whose shade
// follows the posed surface as the body turns and bends, in poses never
// seen as well (R comes from the pose, not from a per-frame code).
//
// Appearance codes (appearance_dim > 0; NeRF in the Wild's appearance
// embeddings): a small ReLU MLP of the encoded point and a frame's code
// (radiance/appearance_codes.h) adds to the colour's logits, so a frame's
// light can brighten or darken any part of the body; density never sees the
// code (the shape is the same in every frame). Its output layer starts at
// zero: an untrained head leaves the colour as it is. Combined with
// "lambert", the code changes the albedo before shading.
#include <torch/torch.h>

#include <array>
#include <string>

#include "fskin/ops/hash_encoding.h"

namespace fskin {

struct RadianceFieldOptions {
  HashEncodingOptions encoding{/*levels=*/12, /*features_per_level=*/2, /*log2_table_size=*/17,
                               /*base_resolution=*/16, /*per_level_scale=*/1.45};
  int64_t hidden_dim = 64;
  int64_t hidden_layers = 2;
  std::string shading = "none";  // "none" or "lambert" (above)
  int64_t appearance_dim = 0;     // length of the per-frame appearance code; 0: none (above)
  int64_t appearance_hidden_dim = 32;
  void validate() const;
  bool lambert() const { return shading == "lambert"; }
};

struct RadianceSample {
  torch::Tensor sigma;  // [N] >= 0, per metre
  torch::Tensor rgb;    // [N, 3] in [0, 1]
};

class RadianceFieldImpl : public torch::nn::Module {
 public:
  // lower / upper: the canonical box (metres); points are normalised by its
  // longest side, so hash cells stay cubes for any proportions.
  RadianceFieldImpl(RadianceFieldOptions options, std::array<double, 3> lower, std::array<double, 3> upper);

  // x [N, 3] canonical -> density and colour (points outside the box have
  // zero density). rotations [N, 3, 3]: the samples' blended bone rotations
  // (canonical -> posed) for Lambert shading; undefined (or shading "none"):
  // the colour is the albedo. appearance [appearance_dim]: the frame's code;
  // undefined: zero (the mean appearance).
  RadianceSample forward(const torch::Tensor& x, const torch::Tensor& rotations = {},
                         const torch::Tensor& appearance = {});
  torch::Tensor density(const torch::Tensor& x) { return forward(x).sigma; }

  const RadianceFieldOptions& options() const { return options_; }
  std::array<double, 3> lower() const { return lower_; }
  std::array<double, 3> upper() const { return upper_; }
  torch::Tensor& table() { return table_; }

 private:
  RadianceFieldOptions options_;
  std::array<double, 3> lower_, upper_;
  double extent_ = 1;     // longest side of the box
  double unit_ = 1;       // length unit (character size / 1.7 m): sigma is per metre at 1.7 m
  torch::Tensor table_;   // [L, 2^T, F]
  torch::nn::Sequential mlp_{nullptr};
  torch::nn::Sequential appearance_mlp_{nullptr};  // appearance_dim > 0
  torch::Tensor light_, ambient_;  // "lambert": d [3] and a's pre-softplus value
};
TORCH_MODULE(RadianceField);

}  // namespace fskin
