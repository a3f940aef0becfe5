#pragma once
// Rotation parameterisations, batched over any leading dimensions and
// differentiable. Matrices act on column vectors (x' = R x), see
// docs/conventions.md.
#include <torch/types.h>

namespace fskin {

// Rodrigues' formula: axis-angle [..., 3] (axis * angle, radians) -> [..., 3, 3].
// Exact gradient at the zero rotation (Taylor expansion near 0).
torch::Tensor axis_angle_to_matrix(const torch::Tensor& axis_angle);

// [..., 3, 3] -> axis-angle [..., 3] with angle in [0, pi].
torch::Tensor matrix_to_axis_angle(const torch::Tensor& rotation);

// Unit quaternions [..., 4] as (w, x, y, z) <-> matrices [..., 3, 3].
torch::Tensor quaternion_to_matrix(const torch::Tensor& quaternion);
torch::Tensor matrix_to_quaternion(const torch::Tensor& rotation);

// Continuous 6D representation (Zhou et al. 2019): the first two columns of the
// matrix, [..., 6] = (c0, c1); decoded by Gram-Schmidt.
torch::Tensor rotation_6d_to_matrix(const torch::Tensor& rotation_6d);
torch::Tensor matrix_to_rotation_6d(const torch::Tensor& rotation);

// Skew-symmetric cross-product matrix [..., 3, 3] of vectors [..., 3].
torch::Tensor skew(const torch::Tensor& v);

}  // namespace fskin
