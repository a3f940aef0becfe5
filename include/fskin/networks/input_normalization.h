#pragma once
// Maps canonical points into the unit cube the networks are initialised for:
// u = (x - centre) * scale. The papers' SMPL bodies already sit around the
// origin at about unit size, so their geometric init (a unit sphere at the
// origin) and Softplus(100) layers fit them; a body standing on y = 0 and
// 1.7 m tall does not, and its training stalled before this mapping.
#include <torch/types.h>

#include <array>

namespace fskin {

struct InputNormalization {
  std::array<double, 3> centre{0.0, 0.0, 0.0};
  double scale = 1.0;

  // The bounding box of points [M, 3] onto [-1, 1] along its longest side.
  static InputNormalization around(const torch::Tensor& points);
  torch::Tensor apply(const torch::Tensor& x) const;    // [..., 3] -> [..., 3]
  torch::Tensor unapply(const torch::Tensor& u) const;  // the inverse of apply
};

}  // namespace fskin
