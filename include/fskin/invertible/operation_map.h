#pragma once
// The rotation and translation maps of an INS coupling layer (eq. 10-11): an
// MLP from the space-and-pose-aware conditioning (eq. 9)
//   c = [z_s * z_p, z_p]      (Hadamard product, then concatenation)
// to the coupling parameters (an angle, or a 1D/2D translation).
//
// - Width of c is 2 E (E = 120: 240, Table 4 row 9). The paper's ablation
//   (section 4.4) contrasts [z_s, z_p] with multiply-then-concatenate; the
//   concatenated half is z_p, not z_s: with z_s the zero pose would still give
//   a space-varying conditioning, against the property eq. 9 is built for.
// - The first layer is computed as W_a (z_s * z_p) + W_b z_p + b, which equals
//   a Linear on the concatenation but evaluates the per-frame W_b z_p once per
//   frame instead of once per point.
// - Last layer zero-initialised (Appendix C.1), so a new coupling layer is the
//   identity.
// - Centred: the map returns MLP(c) - MLP(0). At the zero relative pose z_p = 0
//   (pose_encoding.h), so c = 0 and the layer is the identity (to rounding), not a
//   constant rigid motion; the last layer therefore has no bias (it would cancel).
// Softplus(beta = 100) between layers, as networks/mlp.h.
#include <torch/torch.h>

#include <vector>

namespace fskin {

struct OperationMapOptions {
  int64_t embedding_dim = 120;  // E: width of z_s and of z_p
  int64_t hidden_dim = 32;
  int64_t hidden_layers = 2;  // >= 1
  int64_t output_dim = 1;     // 1 (angle, or 1D translation) or 2 (2D translation)
  // Throws fskin::Error naming the bad field.
  void validate() const;
};

class OperationMapImpl : public torch::nn::Module {
 public:
  explicit OperationMapImpl(const OperationMapOptions& options);
  // space_pose = z_s * z_p [B, N, E], pose = z_p [B, E] -> [B, N, output_dim];
  // 0 (to rounding) where both are 0.
  torch::Tensor forward(const torch::Tensor& space_pose, const torch::Tensor& pose);
  const OperationMapOptions& options() const { return options_; }

 private:
  // The uncentred MLP on c = [space_pose, pose].
  torch::Tensor evaluate(const torch::Tensor& space_pose, const torch::Tensor& pose);

  OperationMapOptions options_;
  torch::nn::Linear first_space_pose_{nullptr};  // W_a, b
  torch::nn::Linear first_pose_{nullptr};        // W_b (no bias)
  std::vector<torch::nn::Linear> hidden_;
  torch::nn::Linear last_{nullptr};  // zero weights, no bias
};
TORCH_MODULE(OperationMap);

}  // namespace fskin
