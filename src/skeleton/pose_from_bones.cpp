#include "fskin/skeleton/pose_from_bones.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {

RecoveredPose pose_from_bone_transforms(const std::vector<int64_t>& parents, const torch::Tensor& rest_joints,
                                        const torch::Tensor& bones) {
  const auto J = static_cast<int64_t>(parents.size());
  expect_shape(rest_joints, {J, 3}, "pose_from_bone_transforms: rest_joints");
  expect_shape(bones, {-1, J, 4, 4}, "pose_from_bone_transforms: bones");
  expect_finite(bones, "pose_from_bone_transforms: bones");
  const auto b = bones.to(torch::kFloat64);
  const auto rest = rest_joints.to(torch::kFloat64);
  // Nearest rotation of each 3x3 (polar decomposition): U V^T, with det +1.
  const auto [u, s, vh] = at::linalg_svd(b.narrow(-2, 0, 3).narrow(-1, 0, 3), /*full_matrices=*/false);
  auto d = torch::ones_like(s);
  d.select(-1, 2).copy_(torch::sign(torch::det(torch::matmul(u, vh))));
  const auto global = torch::matmul(u * d.unsqueeze(-2), vh);  // [T, J, 3, 3]
  std::vector<torch::Tensor> local(static_cast<size_t>(J));
  for (int64_t j = 0; j < J; ++j) {
    const auto q = global.select(1, j);
    local[j] = parents[j] < 0 ? q : torch::matmul(global.select(1, parents[j]).transpose(-1, -2), q);
  }
  const auto local_rotations = torch::stack(local, 1);  // [T, J, 3, 3]
  const auto root = b.select(1, 0);                     // [T, 4, 4]
  const auto root_posed = torch::matmul(root.narrow(-2, 0, 3).narrow(-1, 0, 3), rest[0]) +
                          root.narrow(-2, 0, 3).select(-1, 3);
  RecoveredPose pose;
  pose.root_translation = (root_posed - rest[0]).to(torch::kFloat32);
  pose.local_rotations = matrix_to_axis_angle(local_rotations).to(torch::kFloat32);
  const auto fk = forward_kinematics(parents, rest, local_rotations, root_posed - rest[0]);
  const auto expected = torch::matmul(b.narrow(-2, 0, 3).narrow(-1, 0, 3), rest.unsqueeze(-1)).squeeze(-1) +
                        b.narrow(-2, 0, 3).select(-1, 3);  // [T, J, 3]
  pose.max_joint_drift = (fk.joints - expected).norm(2, -1).max().item<double>();
  pose.max_scale_deviation = (s - 1).abs().max().item<double>();
  auto moved = torch::zeros_like(expected);
  for (int64_t j = 1; j < J; ++j) {
    const int64_t p = parents[j];
    if (p < 0) continue;
    const auto along = torch::matmul(global.select(1, p).transpose(-1, -2),
                                     (expected.select(1, j) - expected.select(1, p)).unsqueeze(-1))
                           .squeeze(-1);
    moved.select(1, j).copy_(along - (rest[j] - rest[p]));
  }
  pose.joint_translations = moved.to(torch::kFloat32);
  return pose;
}

}  // namespace fskin
