#pragma once
// The IDR-style MLP the papers use for skinning and occupancy fields:
// Softplus(beta = 100) between layers, weight normalisation on every layer
// (W = g v / |v| per output row), no output activation, optional skip
// connections (concatenate the network input, divide by sqrt 2), optional
// conditioning vector concatenated at one layer, optional geometric init.
#include <torch/torch.h>

#include <vector>

namespace fskin {

struct MlpOptions {
  int64_t input_dim = 3;
  int64_t output_dim = 1;
  int64_t hidden_dim = 256;
  int64_t hidden_layers = 8;
  // Indices l of linear layers (0 = first) whose input gets the network input
  // concatenated (and is divided by sqrt 2), e.g. {4} for the occupancy network.
  std::vector<int64_t> skip_layers;
  // Width of the conditioning vector (0: none) and the layer whose input gets it.
  int64_t condition_dim = 0;
  int64_t condition_layer = 0;
  // Geometric init (SAL/IDR), sign flipped for occupancy: the initial output is
  // positive inside a sphere of radius `geometric_init_radius`.
  bool geometric_init = false;
  double geometric_init_radius = 1.0;
  double softplus_beta = 100.0;
  // Zero last layer (weights and bias): the network starts as the zero map
  // (displacement fields that start as "no displacement").
  bool zero_output_init = false;
};

// A linear layer with weight normalisation (Salimans & Kingma 2016).
class WeightNormLinearImpl : public torch::nn::Module {
 public:
  WeightNormLinearImpl(int64_t in_features, int64_t out_features);
  torch::Tensor forward(const torch::Tensor& x);
  torch::Tensor weight() const;  // g v / |v|, [out, in]
  // Sets the effective weight (g = |w| per row, v = w) and bias.
  void reset(const torch::Tensor& weight, const torch::Tensor& bias);

  torch::Tensor direction, magnitude, bias;  // v [out, in], g [out, 1], b [out]
};
TORCH_MODULE(WeightNormLinear);

class MlpImpl : public torch::nn::Module {
 public:
  explicit MlpImpl(const MlpOptions& options);
  // x [..., input_dim], condition [..., condition_dim] (required iff
  // condition_dim > 0) -> [..., output_dim].
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& condition = {});
  const MlpOptions& options() const { return options_; }

 private:
  MlpOptions options_;
  std::vector<WeightNormLinear> layers_;
};
TORCH_MODULE(Mlp);

}  // namespace fskin
