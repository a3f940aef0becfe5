#include "fskin/gaussians/gaussian_shading.h"

#include "fskin/core/tensor_checks.h"
#include "fskin/gaussians/spherical_harmonics.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {

torch::Tensor posed_gaussian_normals(const torch::Tensor& rotations, const torch::Tensor& linear) {
  const int64_t n = rotations.size(0);
  expect_shape(rotations, {n, 4}, "posed_gaussian_normals: rotations");
  expect_shape(linear, {n, 3, 3}, "posed_gaussian_normals: linear");
  const auto unit = rotations / rotations.norm(2, 1, true).clamp_min(1e-12);
  const auto axes = torch::matmul(linear, quaternion_to_matrix(unit));  // [N, 3, 3]: the posed axes as columns
  // cross(A x, A y) = det(A) A^-T z.
  const auto normals = torch::cross(axes.select(2, 0), axes.select(2, 1), 1);
  return normals / normals.norm(2, 1, true).clamp_min(1e-12);
}

GaussianShadingImpl::GaussianShadingImpl() {
  auto lighting = torch::zeros({spherical_harmonics_coefficients(2), 3});
  lighting[0] = color_to_spherical_harmonics_dc(torch::ones({3}));  // a shade of 1
  lighting_ = register_parameter("lighting", lighting);
}

torch::Tensor GaussianShadingImpl::forward(const torch::Tensor& normals) {
  expect_shape(normals, {-1, 3}, "gaussian shading: normals");
  return spherical_harmonics_color(lighting_.unsqueeze(0).expand({normals.size(0), -1, -1}), normals);
}

}  // namespace fskin
