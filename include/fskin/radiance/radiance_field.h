#pragma once
// The canonical radiance field of an avatar (Fast-SNARF sec. 7, eq. 18-19;
// InstantAvatar): the multi-resolution hash encoding (ops/hash_encoding.h) of
// the canonical point, normalised into the unit cube of the canonical box,
// followed by a small ReLU MLP (networks/relu_mlp.h) to density sigma >= 0 (per metre) and colour in
// [0, 1]. Colour does not depend on the view direction (the avatar's albedo
// under fixed light).
#include <torch/torch.h>

#include <array>

#include "fskin/ops/hash_encoding.h"

namespace fskin {

struct RadianceFieldOptions {
  HashEncodingOptions encoding{/*levels=*/12, /*features_per_level=*/2, /*log2_table_size=*/17,
                               /*base_resolution=*/16, /*per_level_scale=*/1.45};
  int64_t hidden_dim = 64;
  int64_t hidden_layers = 2;
  void validate() const;
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
  // zero density).
  RadianceSample forward(const torch::Tensor& x);
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
};
TORCH_MODULE(RadianceField);

}  // namespace fskin
