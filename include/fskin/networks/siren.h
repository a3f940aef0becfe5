#pragma once
// SIREN (Sitzmann et al. 2020): an MLP with sine activations, every layer
// h -> sin(w0 (W h + b)). INS uses it as a learned periodic positional
// encoding of the coordinates a coupling layer leaves unchanged (INS eq. 8).
//
// Initialisation follows the SIREN paper: first layer W ~ U(-1/in, 1/in),
// later layers W ~ U(-sqrt(6/in)/w0, sqrt(6/in)/w0); biases keep PyTorch's
// Linear default U(-1/sqrt(in), 1/sqrt(in)). Inputs are expected in about
// [-1, 1] (metres for a body, docs/conventions.md).
//
// Unlike the SIREN paper's signal regressors, the LAST layer is a sine layer
// too, not a linear one: the output is an embedding in [-1, 1] that INS
// multiplies with the pose embedding (eq. 9), so its scale stays fixed and the
// product's scale is set by the pose embedding alone.
#include <torch/torch.h>

#include <vector>

namespace fskin {

struct SirenOptions {
  int64_t input_dim = 3;
  int64_t hidden_dim = 64;
  int64_t output_dim = 120;
  int64_t num_layers = 2;     // sine layers (>= 1); all but the last are hidden_dim wide
  double first_omega = 30.0;  // w0 of the first layer
  double hidden_omega = 30.0; // w0 of the later layers
  // Throws fskin::Error naming the bad field.
  void validate() const;
};

class SirenImpl : public torch::nn::Module {
 public:
  explicit SirenImpl(const SirenOptions& options);
  // x [..., input_dim] -> [..., output_dim], values in [-1, 1].
  torch::Tensor forward(const torch::Tensor& x);
  const SirenOptions& options() const { return options_; }

 private:
  SirenOptions options_;
  std::vector<torch::nn::Linear> layers_;
};
TORCH_MODULE(Siren);

}  // namespace fskin
