#pragma once
// Pose-conditioned coupling layers of INS (section 3.2). A layer splits a point
// x [B, N, 3] into the coordinates it moves, x_a, and the ones it keeps, x_b,
// and changes x_a by a motion whose parameters depend only on x_b and the pose:
//   2D (eq. 5, 10, 11): y_a = R(theta) x_a + t,  x_a in a coordinate plane,
//                       rotation about that plane's origin by one angle theta;
//   1D (eq. 12):        y_a = x_a + t,           x_a one coordinate;
//   y_b = x_b in both. Parameters: theta = M_R(c), t = M_T(c) (operation_map.h)
// with the conditioning c = [z_s * z_p, z_p] (eq. 9, formed inside the maps),
// z_s = SIREN(x_b) (eq. 8),
// z_p the pose embedding of the frame (eq. 7, pose_encoding.h).
//
// Because x_b passes through unchanged, the inverse is closed-form (eq. 6):
// x_a = R(theta)^T (y_a - t) with theta, t computed from y_b = x_b. The
// Jacobian is block-triangular with diagonal blocks R and I, so det = 1
// (Appendix C.2). Each layer starts as the identity (zero last layers,
// Appendix C.1) and is the identity whenever z_p = 0 (exact in arithmetic;
// in floating point to rounding, ~1e-16 in float64).
#include <torch/torch.h>

#include <vector>

#include "fskin/invertible/operation_map.h"
#include "fskin/networks/siren.h"

namespace fskin {

struct CouplingLayerOptions {
  int64_t embedding_dim = 120;  // E: space and pose embeddings (Table 4, rows 7-8)
  // SIREN space embedding x_b -> z_s: num_layers sine layers, the hidden ones
  // space_hidden_dim wide, w0 as in the SIREN paper.
  int64_t space_hidden_dim = 64;
  int64_t space_layers = 2;
  double first_omega = 30.0;
  double hidden_omega = 30.0;
  // SIREN output layer linear instead of sine (siren.h); the operation maps then
  // fold it into their first layer per frame (operation_map.h): a PIN inverse
  // pass measured 2.4x faster at narrow widths, 1.5x at the paper's
  // (docs/ins.md, "Speed").
  bool space_linear_output = false;
  // Rotation and translation maps: 2E -> map_hidden_layers x map_hidden_dim -> out.
  int64_t map_hidden_dim = 32;
  int64_t map_hidden_layers = 2;
  // Throws fskin::Error naming the bad field.
  void validate() const;
};

class CouplingLayer : public torch::nn::Module {
 public:
  // x [B, N, 3], pose_embedding [B, E] -> [B, N, 3].
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& pose_embedding);
  // Exact inverse of forward for the same pose embedding.
  torch::Tensor inverse(const torch::Tensor& y, const torch::Tensor& pose_embedding);

  // Coordinates (0 = x, 1 = y, 2 = z) the layer moves, and those it is conditioned on.
  const std::vector<int64_t>& moved() const { return moved_; }
  const std::vector<int64_t>& kept() const { return kept_; }
  const CouplingLayerOptions& options() const { return options_; }
  const Siren& space_embedding() const { return space_embedding_; }
  // The operation maps in the order the layer evaluates them: 2D: rotation
  // (1 output), translation (2); 1D: translation (1).
  virtual std::vector<OperationMap> maps() const = 0;

 protected:
  CouplingLayer(std::vector<int64_t> moved, const CouplingLayerOptions& options);
  // What the operation maps read: the space embedding of x_b (or, with a
  // linear SIREN output, the features and the projection that make it) and z_p.
  struct Conditioning {
    torch::Tensor space;          // [B, N, E], or [B, N, space_hidden_dim] with a projection
    SpaceProjection projection;   // undefined without
    torch::Tensor pose;           // [B, E]
  };
  // x_a [B, N, |moved|] -> y_a (or y_a -> x_a when `inverse`).
  virtual torch::Tensor transform(const torch::Tensor& x_a, const Conditioning& conditioning, bool inverse) = 0;
  OperationMapOptions map_options(int64_t output_dim) const;
  static torch::Tensor evaluate(OperationMap& map, const Conditioning& c) {
    return map->forward(c.space, c.pose, c.projection);
  }

 private:
  torch::Tensor apply(const torch::Tensor& x, const torch::Tensor& pose_embedding, bool inverse);

  std::vector<int64_t> moved_, kept_;
  CouplingLayerOptions options_;
  Siren space_embedding_{nullptr};
};

// Moves the plane (first, second): rotation by theta from the `first` axis
// towards the `second`, then a 2D translation; conditioned on the third axis.
class CouplingLayer2D : public CouplingLayer {
 public:
  CouplingLayer2D(int64_t first, int64_t second, const CouplingLayerOptions& options = {});
  std::vector<OperationMap> maps() const override { return {rotation_, translation_}; }

 private:
  torch::Tensor transform(const torch::Tensor& x_a, const Conditioning& conditioning, bool inverse) override;
  OperationMap rotation_{nullptr};     // M_R: angle in radians (eq. 10)
  OperationMap translation_{nullptr};  // M_T: 2D translation (eq. 11)
};

// Translates one axis, conditioned on the other two (eq. 12).
class CouplingLayer1D : public CouplingLayer {
 public:
  CouplingLayer1D(int64_t axis, const CouplingLayerOptions& options = {});
  std::vector<OperationMap> maps() const override { return {translation_}; }

 private:
  torch::Tensor transform(const torch::Tensor& x_a, const Conditioning& conditioning, bool inverse) override;
  OperationMap translation_{nullptr};  // M_T: 1D translation
};

}  // namespace fskin
