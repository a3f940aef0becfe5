// EWA projection of 3-D Gaussians: closed-form cases, the local affine
// approximation against a finite-difference Jacobian of the camera's own
// projection, culling, and an optimisation through projection and rasteriser
// that moves a Gaussian onto its target.
#include "fskin/gaussians/gaussian_projection.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <Eigen/Geometry>

#include <cmath>

#include "fskin/ops/gaussian_rasterization.h"
#include "test_util.h"

namespace fskin {
namespace {

PinholeCamera test_camera(int width, int height, double focal) {
  PinholeCamera camera;
  camera.width = width;
  camera.height = height;
  camera.intrinsic << focal, 0, (width - 1) / 2.0, 0, focal, (height - 1) / 2.0, 0, 0, 1;
  return camera;
}

TEST(GaussianProjection, CovariancesComposeScalesAndRotations) {
  // A quarter turn about z swaps the x and y scales; the quaternion need not be unit.
  const double half = std::sqrt(0.5);
  const auto scales = torch::tensor({1.0, 2.0, 3.0}, torch::kFloat64).view({1, 3});
  const auto rotation = torch::tensor({2 * half, 0.0, 0.0, 2 * half}, torch::kFloat64).view({1, 4});
  const auto covariance = gaussian_covariances(scales, rotation)[0];
  const auto expected = torch::diag(torch::tensor({4.0, 1.0, 9.0}, torch::kFloat64));
  EXPECT_LT((covariance - expected).abs().max().item<double>(), 1e-12);
}

TEST(GaussianProjection, AnIsotropicGaussianOnTheAxisProjectsToItsScaledCircle) {
  // Standard deviation 0.1 at depth 2 under focal length 100: 5 pixels, plus the 0.3 dilation.
  const auto camera = test_camera(64, 48, 100);
  const auto means = torch::tensor({0.0, 0.0, 2.0}, torch::kFloat64).view({1, 3});
  const auto covariances = (0.01 * torch::eye(3, torch::kFloat64)).unsqueeze(0);
  const auto p = project_gaussians(means, covariances, camera);
  const double variance = 25 + 0.3;
  EXPECT_NEAR(p.means2d[0][0].item<double>(), 31.5, 1e-12);
  EXPECT_NEAR(p.means2d[0][1].item<double>(), 23.5, 1e-12);
  EXPECT_NEAR(p.conics[0][0].item<double>(), 1 / variance, 1e-12);
  EXPECT_NEAR(p.conics[0][1].item<double>(), 0.0, 1e-12);
  EXPECT_NEAR(p.conics[0][2].item<double>(), 1 / variance, 1e-12);
  EXPECT_EQ(p.radii[0].item<double>(), std::ceil(3 * std::sqrt(variance)));
  EXPECT_EQ(p.depths[0].item<double>(), 2.0);
}

TEST(GaussianProjection, TheFootprintIsTheCameraProjectionLinearisedAtTheMean) {
  // An off-axis, anisotropic Gaussian seen by a turned, shifted camera with
  // skew: J W Sigma W^T J^T against J from finite differences of camera.project.
  auto camera = test_camera(80, 60, 90);
  camera.intrinsic(0, 1) = 3;
  Eigen::Matrix3d r = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  camera.extrinsic.topLeftCorner<3, 3>() = r;
  camera.extrinsic.topRightCorner<3, 1>() = Eigen::Vector3d(0.1, -0.2, 3);
  const Eigen::Vector3d mean(0.3, -0.2, 0.4);
  const auto covariance =
      gaussian_covariances(torch::tensor({0.05, 0.2, 0.1}, torch::kFloat64).view({1, 3}),
                           torch::tensor({0.9, 0.2, -0.3, 0.1}, torch::kFloat64).view({1, 4}));
  ProjectionOptions no_dilation;
  no_dilation.dilation = 0;
  const auto p = project_gaussians(torch::tensor({mean.x(), mean.y(), mean.z()}, torch::kFloat64).view({1, 3}),
                                   covariance, camera, no_dilation);
  Eigen::Matrix<double, 2, 3> jacobian;
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    step[k] = h;
    jacobian.col(k) = (camera.project(mean + step) - camera.project(mean - step)) / (2 * h);
  }
  Eigen::Matrix3d sigma;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) sigma(i, j) = covariance[0][i][j].item<double>();
  const Eigen::Matrix2d expected = jacobian * sigma * jacobian.transpose();
  const Eigen::Matrix2d conic_expected = expected.inverse();
  EXPECT_NEAR(p.conics[0][0].item<double>(), conic_expected(0, 0), 1e-6 * std::abs(conic_expected(0, 0)));
  EXPECT_NEAR(p.conics[0][1].item<double>(), conic_expected(0, 1), 1e-6 * std::abs(conic_expected(0, 0)));
  EXPECT_NEAR(p.conics[0][2].item<double>(), conic_expected(1, 1), 1e-6 * std::abs(conic_expected(1, 1)));
  const Eigen::Vector2d pixel = camera.project(mean);
  EXPECT_NEAR(p.means2d[0][0].item<double>(), pixel.x(), 1e-9);
  EXPECT_NEAR(p.means2d[0][1].item<double>(), pixel.y(), 1e-9);
}

TEST(GaussianProjection, GaussiansBehindTheNearPlaneAreNotDrawnAndStayDifferentiable) {
  const auto camera = test_camera(32, 32, 40);
  auto means = torch::tensor({0.0, 0.0, -1.0, 0.0, 0.0, 0.005, 0.0, 0.0, 1.0}, torch::kFloat64).view({3, 3});
  means.requires_grad_(true);
  const auto covariances = (0.01 * torch::eye(3, torch::kFloat64)).expand({3, 3, 3}).contiguous();
  const auto p = project_gaussians(means, covariances, camera);
  EXPECT_EQ(p.radii[0].item<double>(), 0.0);
  EXPECT_EQ(p.radii[1].item<double>(), 0.0);
  EXPECT_GT(p.radii[2].item<double>(), 0.0);
  (p.means2d.sum() + p.conics.sum()).backward();
  EXPECT_TRUE(torch::isfinite(means.grad()).all().item<bool>());
}

TEST(GaussianProjection, TheDilationsCompensationKeepsASmallFootprintsIntegratedOpacity) {
  // A Gaussian of 0.5 pixel standard deviation: the 0.3 pixel^2 dilation more
  // than doubles its area (0.55 / 0.25), so uncompensated it covers 2.2 times
  // the opacity it should; compensated, its alpha sums to opacity x 2 pi
  // sigma^2 (the footprint is sampled finely enough that the sum is the
  // integral; what the 1/255 cut-off and the 3-sigma box lose is under 2 %).
  const auto camera = test_camera(33, 33, 100);
  const double sigma_pixels = 0.5, depth = 2.0, opacity = 0.99;
  const double sigma = sigma_pixels * depth / 100;
  const auto means = torch::tensor({0.0, 0.0, depth}, torch::kFloat64).view({1, 3});
  const auto covariances = (sigma * sigma * torch::eye(3, torch::kFloat64)).unsqueeze(0);
  ProjectionOptions compensated;
  compensated.compensate = true;
  const auto p = project_gaussians(means, covariances, camera, compensated);
  EXPECT_FALSE(project_gaussians(means, covariances, camera).opacity_compensation.defined());
  EXPECT_NEAR(p.opacity_compensation[0].item<double>(), std::sqrt(0.25 * 0.25 / (0.55 * 0.55)), 1e-9);
  const auto covered = [&](const torch::Tensor& opacities) {
    const auto colors = torch::ones({1, 3}, torch::kFloat64), background = torch::zeros({3}, torch::kFloat64);
    return std::get<1>(rasterize_gaussians(p.means2d, p.conics, colors, opacities, p.depths, p.radii, background,
                                           camera.width, camera.height))
        .sum()
        .item<double>();
  };
  const double integral = opacity * 2 * M_PI * sigma_pixels * sigma_pixels;
  const auto opacities = torch::full({1}, opacity, torch::kFloat64);
  EXPECT_NEAR(covered(opacities * p.opacity_compensation), integral, 0.02 * integral);
  EXPECT_GT(covered(opacities), 1.5 * integral);
}

TEST(GaussianProjection, TheCompensationsGradientMatchesFiniteDifferences) {
  auto camera = test_camera(40, 40, 80);
  camera.extrinsic.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 0.5, 0).normalized()).toRotationMatrix();
  const auto means = torch::tensor({0.05, -0.02, 2.5}, torch::kFloat64).view({1, 3});
  const auto covariance = gaussian_covariances(torch::tensor({0.004, 0.02, 0.01}, torch::kFloat64).view({1, 3}),
                                               torch::tensor({0.8, 0.3, -0.2, 0.1}, torch::kFloat64).view({1, 4}));
  auto variable = covariance.clone().requires_grad_(true);
  const auto compensation = [&](const torch::Tensor& c) {
    ProjectionOptions compensated;
    compensated.compensate = true;
    return project_gaussians(means, c, camera, compensated).opacity_compensation[0];
  };
  const double value = compensation(variable).item<double>();
  EXPECT_GT(value, 0.05);
  EXPECT_LT(value, 0.95);
  compensation(variable).backward();
  const double h = 1e-9;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      auto step = torch::zeros({1, 3, 3}, torch::kFloat64);
      step[0][i][j] = h;
      const double numeric = (compensation(covariance + step).item<double>() -
                              compensation(covariance - step).item<double>()) / (2 * h);
      EXPECT_NEAR(variable.grad()[0][i][j].item<double>(), numeric, 1e-5 * (1 + std::abs(numeric)))
          << "entry " << i << ", " << j;
    }
  }
}

TEST(GaussianProjection, GradientsThroughProjectionAndRasteriserMoveAGaussianOntoItsTarget) {
  // One Gaussian rendered at a target position; a second run starts it 0.15
  // away and follows the picture's gradient back.
  const auto camera = test_camera(48, 48, 60);
  const auto covariances = gaussian_covariances(torch::full({1, 3}, 0.12, torch::kFloat32),
                                                torch::tensor({1.0f, 0.0f, 0.0f, 0.0f}).view({1, 4}));
  const auto colors = torch::tensor({0.9f, 0.6f, 0.2f}).view({1, 3});
  const auto opacities = torch::full({1}, 0.8f), background = torch::zeros({3});
  const auto render = [&](const torch::Tensor& means) {
    const auto p = project_gaussians(means, covariances, camera);
    return std::get<0>(rasterize_gaussians(p.means2d, p.conics, colors, opacities, p.depths, p.radii, background,
                                           camera.width, camera.height));
  };
  const auto target_mean = torch::tensor({0.1f, -0.05f, 2.0f}).view({1, 3});
  const auto target = render(target_mean);
  auto mean = torch::tensor({0.0f, 0.05f, 2.05f}).view({1, 3}).requires_grad_(true);
  torch::optim::Adam optimiser({mean}, torch::optim::AdamOptions(0.01));
  const double start = (mean - target_mean).norm().item<double>();
  for (int step = 0; step < 150; ++step) {
    optimiser.zero_grad();
    (render(mean) - target).square().sum().backward();
    optimiser.step();
  }
  const double end = (mean - target_mean).norm().item<double>();
  EXPECT_GT(start, 0.14);
  EXPECT_LT(end, 0.01) << mean;
}

}  // namespace
}  // namespace fskin
