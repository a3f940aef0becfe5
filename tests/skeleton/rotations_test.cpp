#include "fskin/skeleton/rotations.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

namespace fskin {
namespace {

TEST(Rotations, AxisAngleQuarterTurnAboutZ) {
  const auto r = axis_angle_to_matrix(torch::tensor({0.0, 0.0, M_PI / 2}, torch::kFloat64));
  const auto expected =
      torch::tensor({0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0}, torch::kFloat64).reshape({3, 3});
  EXPECT_TRUE(torch::allclose(r, expected, 1e-12, 1e-12)) << r;
}

TEST(Rotations, AxisAngleMatricesAreRotations) {
  torch::manual_seed(0);
  const auto aa = torch::randn({64, 3}, torch::kFloat64) * 2;
  const auto r = axis_angle_to_matrix(aa);
  const auto eye = torch::eye(3, torch::kFloat64).expand({64, 3, 3});
  EXPECT_TRUE(torch::allclose(torch::matmul(r, r.transpose(1, 2)), eye, 1e-10, 1e-10));
  EXPECT_TRUE(torch::allclose(torch::det(r), torch::ones({64}, torch::kFloat64), 1e-10, 1e-10));
}

TEST(Rotations, AxisAngleRoundTrip) {
  torch::manual_seed(1);
  auto aa = torch::randn({128, 3}, torch::kFloat64);
  // Keep angles below pi where axis-angle is unique.
  aa = aa / aa.norm(2, -1, true) * torch::rand({128, 1}, torch::kFloat64) * 3.0;
  const auto back = matrix_to_axis_angle(axis_angle_to_matrix(aa));
  EXPECT_TRUE(torch::allclose(back, aa, 1e-8, 1e-8));
}

TEST(Rotations, ZeroRotationHasFiniteGradient) {
  auto aa = torch::zeros({1, 3}, torch::dtype(torch::kFloat64).requires_grad(true));
  const auto r = axis_angle_to_matrix(aa);
  r.index({0, 1, 0}).backward();  // d R_10 / d aa_z = 1 at identity
  EXPECT_TRUE(torch::isfinite(aa.grad()).all().item<bool>());
  EXPECT_NEAR(aa.grad()[0][2].item<double>(), 1.0, 1e-12);
}

TEST(Rotations, QuaternionRoundTrip) {
  torch::manual_seed(2);
  const auto r = axis_angle_to_matrix(torch::randn({100, 3}, torch::kFloat64) * 2);
  const auto back = quaternion_to_matrix(matrix_to_quaternion(r));
  EXPECT_TRUE(torch::allclose(back, r, 1e-9, 1e-9));
  // Near-180-degree rotations exercise the other branches of Shepperd's method.
  const auto flip = axis_angle_to_matrix(torch::tensor({{M_PI - 1e-9, 0.0, 0.0}}, torch::kFloat64));
  EXPECT_TRUE(torch::allclose(quaternion_to_matrix(matrix_to_quaternion(flip)), flip, 1e-8, 1e-8));
}

TEST(Rotations, SixDRoundTripAndGramSchmidt) {
  torch::manual_seed(3);
  const auto r = axis_angle_to_matrix(torch::randn({50, 3}, torch::kFloat64));
  EXPECT_TRUE(torch::allclose(rotation_6d_to_matrix(matrix_to_rotation_6d(r)), r, 1e-10, 1e-10));
  // Any (non-degenerate) 6D vector decodes to a proper rotation.
  const auto q = rotation_6d_to_matrix(torch::randn({50, 6}, torch::kFloat64));
  EXPECT_TRUE(torch::allclose(torch::det(q), torch::ones({50}, torch::kFloat64), 1e-10, 1e-10));
}

TEST(Rotations, BadShapesThrow) {
  EXPECT_THROW(axis_angle_to_matrix(torch::zeros({4, 2})), std::runtime_error);
  EXPECT_THROW(rotation_6d_to_matrix(torch::zeros({4, 5})), std::runtime_error);
}

}  // namespace
}  // namespace fskin
