#include "fskin/skeleton/forward_kinematics.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "fskin/skeleton/lbs.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {
namespace {

const auto kF64 = torch::kFloat64;

// A chain root(0,0,0) -> elbow(1,0,0) -> tip(2,0,0).
torch::Tensor chain_joints() {
  return torch::tensor({0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0}, kF64).reshape({3, 3});
}

TEST(ForwardKinematics, IdentityPoseGivesIdentityBones) {
  const auto rot = torch::eye(3, kF64).expand({2, 3, 3, 3});
  const auto out = forward_kinematics({-1, 0, 1}, chain_joints(), rot);
  EXPECT_TRUE(torch::allclose(out.bone_transforms, torch::eye(4, kF64).expand({2, 3, 4, 4})));
  EXPECT_TRUE(torch::allclose(out.joints[0], chain_joints()));
}

TEST(ForwardKinematics, HandComputedChain) {
  // Root turns +90 deg about z, elbow turns another +90 deg about z, root moves by (0,0,5).
  auto aa = torch::zeros({1, 3, 3}, kF64);
  aa[0][0][2] = M_PI / 2;
  aa[0][1][2] = M_PI / 2;
  const auto trans = torch::tensor({{0.0, 0.0, 5.0}}, kF64);
  const auto out =
      forward_kinematics({-1, 0, 1}, chain_joints(), axis_angle_to_matrix(aa), trans);
  // Elbow: (1,0,0) rotated by 90 deg -> (0,1,0), plus translation.
  EXPECT_TRUE(torch::allclose(out.joints[0][1], torch::tensor({0.0, 1.0, 5.0}, kF64), 1e-12, 1e-12));
  // Tip: elbow + (1,0,0) rotated by 180 deg -> (-1,1,0).
  EXPECT_TRUE(torch::allclose(out.joints[0][2], torch::tensor({-1.0, 1.0, 5.0}, kF64), 1e-12, 1e-12));
  // A rest point on the forearm (1.5,0,0) moves rigidly with bone 1 to (-0.5,1,5).
  const auto p = transform_points(out.bone_transforms[0][1], torch::tensor({1.5, 0.0, 0.0}, kF64));
  EXPECT_TRUE(torch::allclose(p, torch::tensor({-0.5, 1.0, 5.0}, kF64), 1e-12, 1e-12));
}

TEST(ForwardKinematics, JointTranslationsMoveAJointInItsParentsFrame) {
  // Root turns +90 deg about z; the elbow is pushed 0.5 along the root's x
  // (its bone stretches), the tip 0.25 along the elbow's y.
  auto aa = torch::zeros({1, 3, 3}, kF64);
  aa[0][0][2] = M_PI / 2;
  auto moved = torch::zeros({1, 3, 3}, kF64);
  moved[0][1][0] = 0.5;
  moved[0][2][1] = 0.25;
  const auto out = forward_kinematics({-1, 0, 1}, chain_joints(), axis_angle_to_matrix(aa), {}, moved);
  EXPECT_TRUE(torch::allclose(out.joints[0][1], torch::tensor({0.0, 1.5, 0.0}, kF64), 1e-12, 1e-12));
  EXPECT_TRUE(torch::allclose(out.joints[0][2], torch::tensor({-0.25, 2.5, 0.0}, kF64), 1e-12, 1e-12));
  // A root entry adds to the root translation.
  auto root_moved = torch::zeros({1, 3, 3}, kF64);
  root_moved[0][0][2] = 2.0;
  const auto shifted = forward_kinematics({-1, 0, 1}, chain_joints(), axis_angle_to_matrix(aa), {}, root_moved);
  EXPECT_TRUE(torch::allclose(shifted.joints[0][2], torch::tensor({0.0, 2.0, 2.0}, kF64), 1e-12, 1e-12));
  EXPECT_THROW(forward_kinematics({-1, 0, 1}, chain_joints(), axis_angle_to_matrix(aa), {}, torch::zeros({1, 2, 3})),
               std::runtime_error);
}

TEST(ForwardKinematics, RelativeTransformsComposeToTarget) {
  torch::manual_seed(0);
  const auto a = forward_kinematics({-1, 0, 1}, chain_joints(),
                                    axis_angle_to_matrix(torch::randn({4, 3, 3}, kF64)));
  const auto b = forward_kinematics({-1, 0, 1}, chain_joints(),
                                    axis_angle_to_matrix(torch::randn({4, 3, 3}, kF64)));
  // canonical -> posed composed with rest -> canonical equals rest -> posed.
  const auto rel = relative_bone_transforms(b.bone_transforms, a.bone_transforms);
  EXPECT_TRUE(torch::allclose(torch::matmul(rel, a.bone_transforms), b.bone_transforms, 1e-10, 1e-10));
}

TEST(ForwardKinematics, RejectsBadShapes) {
  EXPECT_THROW(forward_kinematics({-1, 0}, chain_joints(), torch::eye(3).expand({1, 3, 3, 3})),
               std::runtime_error);
  EXPECT_THROW(forward_kinematics({}, chain_joints(), torch::eye(3).expand({1, 3, 3, 3})),
               std::runtime_error);
}

}  // namespace
}  // namespace fskin
