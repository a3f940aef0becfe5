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
// - The first layer, W_a (z_s * z_p) + W_b z_p + b (a Linear on the
//   concatenation), is evaluated per frame as one matrix on the points' space
//   features: (W_a diag(z_p)) z_s + (W_b z_p + b). When z_s comes out of a
//   linear layer, z_s = P f + p (a SIREN with linear_output, siren.h), that
//   layer folds in too, (W_a diag(z_p) P) f + W_a (p * z_p) + W_b z_p + b, so
//   the E-wide z_s is never formed per point: per point the cost is F x hidden
//   instead of (F + hidden) x E. Exact (same function, same gradients).
// - Last layer zero-initialised (Appendix C.1), so a new coupling layer is the
//   identity.
// - Centred: the map returns MLP(c) - MLP(0). At the zero relative pose z_p = 0
//   (pose_encoding.h), so c = 0 and the layer is the identity (to rounding), not a
//   constant rigid motion; the last layer therefore has no bias (it would cancel).
// Softplus(beta = 100) between layers, as networks/mlp.h.
#include <torch/torch.h>

#include <vector>

namespace fskin {

// The linear last layer of a space embedding, z_s = f W^T + b.
struct SpaceProjection {
  torch::Tensor weight;  // [E, F]
  torch::Tensor bias;    // [E]
};

struct OperationMapOptions {
  int64_t embedding_dim = 120;  // E: width of z_s and of z_p
  int64_t hidden_dim = 32;
  int64_t hidden_layers = 2;  // >= 1
  int64_t output_dim = 1;     // 1 (angle, or 1D translation) or 2 (2D translation)
  // Throws fskin::Error naming the bad field.
  void validate() const;
};

// The first layer evaluated for given pose embeddings: pre = f A^T + a, with f
// the space embedding (or, with a projection, the features it is made from).
struct FoldedFirstLayer {
  torch::Tensor weight;  // A [B, hidden, E or F]
  torch::Tensor bias;    // a [B, hidden]
};

class OperationMapImpl : public torch::nn::Module {
 public:
  // beta of the Softplus between layers.
  static constexpr double kSoftplusBeta = 100.0;

  explicit OperationMapImpl(const OperationMapOptions& options);
  // space = z_s [B, N, E], pose = z_p [B, E] -> [B, N, output_dim]; 0 (to
  // rounding) where z_p = 0. With a projection, space holds the features
  // f [B, N, F] and z_s = f W^T + b.
  torch::Tensor forward(const torch::Tensor& space, const torch::Tensor& pose, const SpaceProjection& projection = {});
  const OperationMapOptions& options() const { return options_; }

  // The pieces the fused PIN pass (fused_pin_pass.h) packs per frame.
  FoldedFirstLayer fold(const torch::Tensor& pose, const SpaceProjection& projection = {});
  const std::vector<torch::nn::Linear>& hidden_layers() const { return hidden_; }
  torch::nn::Linear last_layer() const { return last_; }
  // The uncentred MLP at c = 0, which forward subtracts: [output_dim].
  torch::Tensor at_zero_conditioning();

 private:
  // The uncentred MLP after its first layer's affine map: pre-activation [..., hidden] -> [..., output_dim].
  torch::Tensor evaluate(torch::Tensor pre_activation);

  OperationMapOptions options_;
  torch::nn::Linear first_space_pose_{nullptr};  // W_a, b
  torch::nn::Linear first_pose_{nullptr};        // W_b (no bias)
  std::vector<torch::nn::Linear> hidden_;
  torch::nn::Linear last_{nullptr};  // zero weights, no bias
};
TORCH_MODULE(OperationMap);

}  // namespace fskin
