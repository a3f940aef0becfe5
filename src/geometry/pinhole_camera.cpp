#include "fskin/geometry/pinhole_camera.h"

#include <Eigen/Dense>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

Eigen::Vector3d PinholeCamera::centre() const {
  const Eigen::Matrix3d rotation = extrinsic.topLeftCorner<3, 3>();
  return -rotation.transpose() * extrinsic.topRightCorner<3, 1>();
}

Eigen::Vector3d PinholeCamera::right() const { return extrinsic.block<1, 3>(0, 0).transpose(); }
Eigen::Vector3d PinholeCamera::down() const { return extrinsic.block<1, 3>(1, 0).transpose(); }
Eigen::Vector3d PinholeCamera::forward() const { return extrinsic.block<1, 3>(2, 0).transpose(); }

Eigen::Vector3d PinholeCamera::to_camera(const Eigen::Vector3d& world) const {
  return extrinsic.topLeftCorner<3, 3>() * world + extrinsic.topRightCorner<3, 1>();
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& world) const {
  const Eigen::Vector3d p = to_camera(world);
  const Eigen::Vector3d q = intrinsic * (p / p.z());
  return {q.x(), q.y()};
}

PinholeCamera PinholeCamera::supersampled(int factor) const {
  FSKIN_CHECK(factor >= 1 && factor <= 64, "camera: supersampling factor must be within 1..64, got {}", factor);
  PinholeCamera fine = *this;
  fine.width = width * factor;
  fine.height = height * factor;
  // Pixel u's left edge is at u - 0.5: an edge position e maps to factor * e.
  fine.intrinsic.topRows<2>() *= factor;
  fine.intrinsic(0, 2) = factor * (intrinsic(0, 2) + 0.5) - 0.5;
  fine.intrinsic(1, 2) = factor * (intrinsic(1, 2) + 0.5) - 0.5;
  return fine;
}

PinholeCamera PinholeCamera::cropped(int64_t u0, int64_t v0, int64_t u1, int64_t v1) const {
  FSKIN_CHECK(0 <= u0 && u0 < u1 && u1 <= width && 0 <= v0 && v0 < v1 && v1 <= height,
              "camera: crop box [{}, {}) x [{}, {}) is not inside the {} x {} picture", u0, u1, v0, v1, width, height);
  PinholeCamera box = *this;
  box.intrinsic(0, 2) -= static_cast<double>(u0);
  box.intrinsic(1, 2) -= static_cast<double>(v0);
  box.width = static_cast<int>(u1 - u0);
  box.height = static_cast<int>(v1 - v0);
  return box;
}

PinholeCamera PinholeCamera::orbited(double radians, const Eigen::Vector3d& pivot) const {
  return turned(Eigen::Vector3d::UnitY(), radians, pivot);
}

PinholeCamera PinholeCamera::turned(const Eigen::Vector3d& axis, double radians, const Eigen::Vector3d& pivot) const {
  Eigen::Matrix4d turn = Eigen::Matrix4d::Identity();
  turn.topLeftCorner<3, 3>() = Eigen::AngleAxisd(radians, axis.normalized()).toRotationMatrix();
  turn.topRightCorner<3, 1>() = pivot - turn.topLeftCorner<3, 3>() * pivot;
  PinholeCamera out = *this;
  out.extrinsic = extrinsic * turn;  // the world turned by `turn`, then seen by this camera
  return out;
}

PinholeCamera PinholeCamera::from_matrices(const torch::Tensor& intrinsic, const torch::Tensor& extrinsic, int width,
                                          int height, const std::string& context) {
  expect_floating(intrinsic, context + ": intrinsic");
  expect_floating(extrinsic, context + ": extrinsic");
  expect_shape(intrinsic, {3, 3}, context + ": intrinsic");
  expect_shape(extrinsic, {4, 4}, context + ": extrinsic");
  const auto k = intrinsic.detach().to(torch::kCPU, torch::kFloat64).contiguous();
  const auto e = extrinsic.detach().to(torch::kCPU, torch::kFloat64).contiguous();
  PinholeCamera camera;
  camera.width = width;
  camera.height = height;
  camera.intrinsic = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(k.data_ptr<double>());
  camera.extrinsic = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(e.data_ptr<double>());
  camera.validate(context);
  return camera;
}

void PinholeCamera::validate(const std::string& context) const {
  FSKIN_CHECK(width > 0 && height > 0, "{}: image size must be positive, got {}x{}", context, width, height);
  FSKIN_CHECK(intrinsic.allFinite() && extrinsic.allFinite(), "{}: camera matrices are not finite", context);
  FSKIN_CHECK(intrinsic(1, 0) == 0 && intrinsic(2, 0) == 0 && intrinsic(2, 1) == 0 && intrinsic(2, 2) == 1,
              "{}: intrinsic must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]]", context);
  FSKIN_CHECK(intrinsic(0, 0) > 0 && intrinsic(1, 1) > 0, "{}: focal lengths must be positive, got {} and {}",
              context, intrinsic(0, 0), intrinsic(1, 1));
  // A focal length of 10^4 image sides is a field of view of 0.006 degrees:
  // beyond it the value is corrupt, not a lens.
  const double side = std::max(width, height);
  FSKIN_CHECK(intrinsic(0, 0) <= 1e4 * side && intrinsic(1, 1) <= 1e4 * side,
              "{}: focal lengths {:.4g} and {:.4g} pixels are beyond 10^4 times the {}x{} image", context,
              intrinsic(0, 0), intrinsic(1, 1), width, height);
  FSKIN_CHECK(std::abs(intrinsic(0, 1)) <= intrinsic(0, 0) && std::abs(intrinsic(0, 2)) <= 10 * side &&
                  std::abs(intrinsic(1, 2)) <= 10 * side,
              "{}: skew {:.4g} or principal point ({:.4g}, {:.4g}) is far outside the {}x{} image", context,
              intrinsic(0, 1), intrinsic(0, 2), intrinsic(1, 2), width, height);
  FSKIN_CHECK(extrinsic.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)),
              "{}: extrinsic's last row must be [0, 0, 0, 1]", context);
  const Eigen::Matrix3d rotation = extrinsic.topLeftCorner<3, 3>();
  FSKIN_CHECK((rotation * rotation.transpose()).isApprox(Eigen::Matrix3d::Identity(), 1e-4) &&
                  std::abs(rotation.determinant() - 1) < 1e-4,
              "{}: extrinsic's rotation is not a rotation (R R^T != I or det != 1): a world->camera "
              "transform without scale is expected",
              context);
}

std::pair<torch::Tensor, torch::Tensor> camera_rays(const PinholeCamera& camera, const torch::Tensor& pixels) {
  expect_shape(pixels, {-1, 2}, "camera_rays: pixels");
  const auto uv = pixels.to(torch::kFloat64);
  const auto& K = camera.intrinsic;
  const auto y = (uv.select(1, 1) - K(1, 2)) / K(1, 1);
  const auto x = (uv.select(1, 0) - K(0, 2) - K(0, 1) * y) / K(0, 0);
  const auto local = torch::stack({x, y, torch::ones_like(x)}, 1);  // camera space
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> rotation = camera.extrinsic.topLeftCorner<3, 3>();
  const auto R = torch::from_blob(rotation.data(), {3, 3}, torch::kFloat64).clone();
  // world = R^T camera: rows of `local` times R.
  auto directions = local.matmul(R);
  directions = directions / directions.norm(2, 1, true);
  const Eigen::Vector3d eye = camera.centre();
  const auto origins = torch::tensor({eye.x(), eye.y(), eye.z()}, torch::kFloat64).expand({uv.size(0), 3});
  return {origins.to(torch::kFloat32).contiguous(), directions.to(torch::kFloat32).contiguous()};
}

torch::Tensor pixel_centres(int width, int height) {
  FSKIN_CHECK(width > 0 && height > 0, "pixel_centres: size must be positive, got {}x{}", width, height);
  const auto u = torch::arange(width, torch::kFloat32), v = torch::arange(height, torch::kFloat32);
  const auto grids = torch::meshgrid({v, u}, "ij");
  return torch::stack({grids[1].reshape(-1), grids[0].reshape(-1)}, 1).contiguous();
}

}  // namespace fskin
