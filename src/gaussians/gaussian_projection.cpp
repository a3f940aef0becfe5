#include "fskin/gaussians/gaussian_projection.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {

torch::Tensor gaussian_covariances(const torch::Tensor& scales, const torch::Tensor& rotations) {
  expect_shape(scales, {-1, 3}, "gaussian_covariances: scales");
  expect_shape(rotations, {scales.size(0), 4}, "gaussian_covariances: rotations");
  const auto unit = rotations / rotations.norm(2, -1, true).clamp_min(1e-12);
  const auto r = quaternion_to_matrix(unit);
  const auto rs = r * scales.unsqueeze(1);  // R diag(s): column j scaled by s_j
  return torch::matmul(rs, rs.transpose(1, 2));
}

ProjectedGaussians project_gaussians(const torch::Tensor& means, const torch::Tensor& covariances,
                                     const PinholeCamera& camera, const ProjectionOptions& options) {
  expect_shape(means, {-1, 3}, "project_gaussians: means");
  expect_shape(covariances, {means.size(0), 3, 3}, "project_gaussians: covariances");
  expect_floating(means, "project_gaussians: means");
  FSKIN_CHECK(covariances.scalar_type() == means.scalar_type() && covariances.device() == means.device(),
              "project_gaussians: means and covariances must share one dtype and device");
  FSKIN_CHECK(options.near > 0 && options.dilation >= 0 && options.extent > 0,
              "project_gaussians: near and extent must be positive and dilation not negative");
  camera.validate("project_gaussians: camera");
  auto rotation = torch::empty({3, 3}, torch::kFloat64), translation = torch::empty({3}, torch::kFloat64);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) rotation[i][j] = camera.extrinsic(i, j);
    translation[i] = camera.extrinsic(i, 3);
  }
  rotation = rotation.to(means.options());
  translation = translation.to(means.options());
  const auto k = camera.intrinsic;
  const auto p = torch::matmul(means, rotation.t()) + translation;  // camera space [N, 3]
  const auto x = p.select(1, 0), y = p.select(1, 1), z = p.select(1, 2);
  const auto in_front = z > options.near;
  // Behind the near plane the Jacobian is meaningless: evaluate it at a safe depth, radius 0 hides the result.
  const auto zs = torch::where(in_front, z, torch::full_like(z, options.near));
  const double fx = k(0, 0), skew = k(0, 1), cx = k(0, 2), fy = k(1, 1), cy = k(1, 2);
  ProjectedGaussians out;
  out.means2d = torch::stack({(fx * x + skew * y) / zs + cx, fy * y / zs + cy}, 1);
  out.depths = z;
  // J = d(u, v) / d(x, y, z) [N, 2, 3].
  const auto zero = torch::zeros_like(zs);
  const auto j = torch::stack({torch::stack({fx / zs, skew / zs, -(fx * x + skew * y) / (zs * zs)}, 1),
                               torch::stack({zero, fy / zs, -fy * y / (zs * zs)}, 1)},
                              1);
  const auto jw = torch::matmul(j, rotation);  // [N, 2, 3]
  const auto cov2d = torch::matmul(torch::matmul(jw, covariances), jw.transpose(1, 2));
  const auto a0 = cov2d.select(1, 0).select(1, 0);
  const auto b = cov2d.select(1, 0).select(1, 1);
  const auto c0 = cov2d.select(1, 1).select(1, 1);
  const auto a = a0 + options.dilation, c = c0 + options.dilation;
  const auto det = a * c - b * b;
  const auto drawn = in_front & (det > 0) & torch::isfinite(det);
  const auto safe_det = torch::where(drawn, det, torch::ones_like(det));
  out.conics = torch::stack({c / safe_det, -b / safe_det, a / safe_det}, 1);
  if (options.compensate) {
    // Floored below 1e-12 (a footprint of no area): sqrt's slope there is finite and the factor ~0.
    const auto ratio = ((a0 * c0 - b * b) / safe_det).clamp(1e-12, 1.0);
    out.opacity_compensation = torch::where(drawn, torch::sqrt(ratio), torch::ones_like(ratio));
  }
  torch::NoGradGuard no_grad;
  const auto middle = 0.5 * (a + c);
  const auto largest = middle + torch::sqrt(torch::clamp_min(middle * middle - det, 0.0));
  const auto radius = torch::ceil(options.extent * torch::sqrt(largest.clamp_min(0.0)));
  out.radii = torch::where(drawn, radius, torch::zeros_like(radius)).detach();
  return out;
}

}  // namespace fskin
