#include "fskin/skeleton/pose_from_bones.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {
namespace {

const auto kF64 = torch::kFloat64;

// A branching skeleton: root -> a -> b, root -> c.
const std::vector<int64_t> kParents = {-1, 0, 1, 0};
torch::Tensor rest() { return torch::tensor({{0.0, 1.0, 0.0}, {0.0, 1.5, 0.1}, {0.2, 2.0, 0.1}, {0.4, 0.9, 0.0}}, kF64); }

TEST(PoseFromBones, RecoversRotationsRootAndJointTranslations) {
  torch::manual_seed(3);
  const int64_t T = 5;
  const auto aa = torch::randn({T, 4, 3}, kF64) * 0.7;
  const auto trans = torch::randn({T, 3}, kF64);
  auto moved = torch::randn({T, 4, 3}, kF64) * 0.1;
  moved.select(1, 0).zero_();
  const auto fk = forward_kinematics(kParents, rest(), axis_angle_to_matrix(aa), trans, moved);
  const auto pose = pose_from_bone_transforms(kParents, rest(), fk.bone_transforms);
  EXPECT_TRUE(torch::allclose(axis_angle_to_matrix(pose.local_rotations.to(kF64)), axis_angle_to_matrix(aa), 1e-5, 1e-5));
  EXPECT_TRUE(torch::allclose(pose.root_translation.to(kF64), trans, 1e-5, 1e-5));
  EXPECT_TRUE(torch::allclose(pose.joint_translations.to(kF64), moved, 1e-5, 1e-5));
  // Without the translations the joints would be off by about their size.
  EXPECT_GT(pose.max_joint_drift, 0.05);
  EXPECT_LT(pose.max_scale_deviation, 1e-9);
  const auto again = forward_kinematics(kParents, rest(), axis_angle_to_matrix(pose.local_rotations.to(kF64)),
                                        pose.root_translation.to(kF64), pose.joint_translations.to(kF64));
  EXPECT_LT((again.bone_transforms - fk.bone_transforms).abs().max().item<double>(), 1e-5);
}

TEST(PoseFromBones, RotationsOnlyHaveNoDriftAndScaleIsReported) {
  torch::manual_seed(4);
  const auto fk = forward_kinematics(kParents, rest(), axis_angle_to_matrix(torch::randn({3, 4, 3}, kF64)));
  const auto pose = pose_from_bone_transforms(kParents, rest(), fk.bone_transforms);
  EXPECT_LT(pose.max_joint_drift, 1e-9);
  EXPECT_LT(pose.joint_translations.abs().max().item<float>(), 1e-5);
  auto scaled = fk.bone_transforms.clone();
  scaled.select(1, 2).narrow(-2, 0, 3).narrow(-1, 0, 3).mul_(1.1);
  EXPECT_NEAR(pose_from_bone_transforms(kParents, rest(), scaled).max_scale_deviation, 0.1, 1e-9);
}

}  // namespace
}  // namespace fskin
