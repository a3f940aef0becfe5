#include "fskin/skeleton/rotations.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

using torch::indexing::Ellipsis;
using torch::indexing::Slice;

torch::Tensor skew(const torch::Tensor& v) {
  FSKIN_CHECK(v.dim() >= 1 && v.size(-1) == 3, "skew: expected [..., 3], got {}",
              shape_string(v.sizes()));
  const auto x = v.select(-1, 0), y = v.select(-1, 1), z = v.select(-1, 2);
  const auto o = torch::zeros_like(x);
  auto shape = v.sizes().vec();
  shape.push_back(3);
  return torch::stack({o, -z, y, z, o, -x, -y, x, o}, -1).reshape(shape);
}

torch::Tensor axis_angle_to_matrix(const torch::Tensor& axis_angle) {
  FSKIN_CHECK(axis_angle.dim() >= 1 && axis_angle.size(-1) == 3,
              "axis_angle_to_matrix: expected [..., 3], got {}", shape_string(axis_angle.sizes()));
  // R = I + a K + b K^2 with K = skew(axis * angle), a = sin(t)/t, b = (1-cos t)/t^2.
  // Both coefficients are smooth in t^2, so near 0 we switch to their Taylor series
  // and never divide by a vanishing angle (keeps the gradient finite at identity).
  const auto theta2 = (axis_angle * axis_angle).sum(-1, /*keepdim=*/true).unsqueeze(-1);
  const auto small = theta2 < 1e-6;
  const auto safe_theta2 = torch::where(small, torch::ones_like(theta2), theta2);
  const auto safe_theta = safe_theta2.sqrt();
  const auto a = torch::where(small, 1.0 - theta2 / 6.0, safe_theta.sin() / safe_theta);
  const auto b = torch::where(small, 0.5 - theta2 / 24.0, (1.0 - safe_theta.cos()) / safe_theta2);
  const auto k = skew(axis_angle);
  const auto eye = torch::eye(3, axis_angle.options()).expand_as(k);
  return eye + a * k + b * torch::matmul(k, k);
}

torch::Tensor quaternion_to_matrix(const torch::Tensor& quaternion) {
  FSKIN_CHECK(quaternion.dim() >= 1 && quaternion.size(-1) == 4,
              "quaternion_to_matrix: expected [..., 4], got {}", shape_string(quaternion.sizes()));
  const auto q = quaternion / quaternion.norm(2, -1, true);
  const auto w = q.select(-1, 0), x = q.select(-1, 1), y = q.select(-1, 2), z = q.select(-1, 3);
  auto rows = torch::stack({1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)},
                           -1);
  auto shape = quaternion.sizes().vec();
  shape.back() = 3;
  shape.push_back(3);
  return rows.reshape(shape);
}

torch::Tensor matrix_to_quaternion(const torch::Tensor& rotation) {
  FSKIN_CHECK(rotation.dim() >= 2 && rotation.size(-1) == 3 && rotation.size(-2) == 3,
              "matrix_to_quaternion: expected [..., 3, 3], got {}", shape_string(rotation.sizes()));
  // Shepperd's method: compute all four candidate quaternions and keep the one
  // whose largest component is best conditioned.
  const auto m = rotation;
  const auto m00 = m.index({Ellipsis, 0, 0}), m11 = m.index({Ellipsis, 1, 1}),
             m22 = m.index({Ellipsis, 2, 2});
  const auto m01 = m.index({Ellipsis, 0, 1}), m10 = m.index({Ellipsis, 1, 0});
  const auto m02 = m.index({Ellipsis, 0, 2}), m20 = m.index({Ellipsis, 2, 0});
  const auto m12 = m.index({Ellipsis, 1, 2}), m21 = m.index({Ellipsis, 2, 1});
  const auto four_w2 = 1 + m00 + m11 + m22;
  const auto four_x2 = 1 + m00 - m11 - m22;
  const auto four_y2 = 1 - m00 + m11 - m22;
  const auto four_z2 = 1 - m00 - m11 + m22;
  const auto cand = torch::stack(
      {torch::stack({four_w2, m21 - m12, m02 - m20, m10 - m01}, -1),
       torch::stack({m21 - m12, four_x2, m10 + m01, m02 + m20}, -1),
       torch::stack({m02 - m20, m10 + m01, four_y2, m12 + m21}, -1),
       torch::stack({m10 - m01, m20 + m02, m21 + m12, four_z2}, -1)},
      -2);  // [..., 4 candidates, 4]
  const auto diag = torch::stack({four_w2, four_x2, four_y2, four_z2}, -1);
  const auto best = diag.argmax(-1, /*keepdim=*/true);  // [..., 1]
  const auto denom = 2.0 * diag.gather(-1, best).clamp_min(1e-12).sqrt();  // [..., 1]
  auto idx_shape = best.sizes().vec();
  idx_shape.push_back(4);
  const auto q = cand.gather(-2, best.unsqueeze(-1).expand(idx_shape)).squeeze(-2) / denom;
  // Canonical sign: w >= 0.
  return torch::where(q.select(-1, 0).unsqueeze(-1) < 0, -q, q);
}

torch::Tensor matrix_to_axis_angle(const torch::Tensor& rotation) {
  const auto q = matrix_to_quaternion(rotation);
  const auto w = q.select(-1, 0).unsqueeze(-1);
  const auto xyz = q.index({Ellipsis, Slice(1, 4)});
  const auto s = xyz.norm(2, -1, true);
  const auto angle = 2.0 * torch::atan2(s, w);  // in [0, pi] because w >= 0
  // angle / sin(angle/2) -> 2 as the angle -> 0.
  const auto small = s < 1e-6;
  const auto factor = torch::where(small, 2.0 / w.clamp_min(1e-12),
                                   angle / torch::where(small, torch::ones_like(s), s));
  return xyz * factor;
}

torch::Tensor rotation_6d_to_matrix(const torch::Tensor& rotation_6d) {
  FSKIN_CHECK(rotation_6d.dim() >= 1 && rotation_6d.size(-1) == 6,
              "rotation_6d_to_matrix: expected [..., 6], got {}",
              shape_string(rotation_6d.sizes()));
  const auto a1 = rotation_6d.index({Ellipsis, Slice(0, 3)});
  const auto a2 = rotation_6d.index({Ellipsis, Slice(3, 6)});
  const auto b1 = a1 / a1.norm(2, -1, true).clamp_min(1e-12);
  auto b2 = a2 - (b1 * a2).sum(-1, true) * b1;
  b2 = b2 / b2.norm(2, -1, true).clamp_min(1e-12);
  const auto b3 = torch::cross(b1, b2, -1);
  return torch::stack({b1, b2, b3}, -1);  // columns
}

torch::Tensor matrix_to_rotation_6d(const torch::Tensor& rotation) {
  return torch::cat({rotation.index({Ellipsis, Slice(), 0}), rotation.index({Ellipsis, Slice(), 1})},
                    -1);
}

}  // namespace fskin
