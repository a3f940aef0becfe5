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
// Output layer, by option:
// - sine (default): the last layer is a sine layer too, not the SIREN paper's
//   linear one, so the output is an embedding in [-1, 1] that INS multiplies
//   with the pose embedding (eq. 9): its scale stays fixed and the product's
//   scale is set by the pose embedding alone.
// - linear (linear_output): the SIREN paper's form, W h + b. A linear last
//   layer can be folded into whatever linear map consumes the embedding
//   (operation_map.h does this per frame), so the output_dim-wide embedding is
//   never formed per point. Initialised W ~ U(-sqrt(6/in), sqrt(6/in)), the
//   hidden layers' bound without 1/w0: outputs have unit variance, as w0 W h
//   has before a sine.
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
  bool linear_output = false;  // last layer W h + b instead of sin(w0 (W h + b)); needs num_layers >= 2
  // Throws fskin::Error naming the bad field.
  void validate() const;
};

class SirenImpl : public torch::nn::Module {
 public:
  explicit SirenImpl(const SirenOptions& options);
  // x [..., input_dim] -> [..., output_dim]; values in [-1, 1] unless linear_output.
  torch::Tensor forward(const torch::Tensor& x);
  // The features the last layer reads: x [..., input_dim] -> [..., hidden_dim]
  // (the input itself when num_layers == 1).
  torch::Tensor hidden(const torch::Tensor& x);
  // forward(x) == output_layer()(hidden(x)) when linear_output.
  torch::nn::Linear output_layer() const { return layers_.back(); }
  // All layers, the first input_dim -> hidden_dim; layer l's w0 is
  // first_omega for l = 0, else hidden_omega.
  const std::vector<torch::nn::Linear>& layers() const { return layers_; }
  const SirenOptions& options() const { return options_; }

 private:
  SirenOptions options_;
  std::vector<torch::nn::Linear> layers_;
};
TORCH_MODULE(Siren);

}  // namespace fskin
