#include "fskin/skeleton/forward_kinematics.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {

PosedSkeleton forward_kinematics(const std::vector<int64_t>& parents,
                                 const torch::Tensor& rest_joints,
                                 const torch::Tensor& local_rotations,
                                 const torch::Tensor& root_translation,
                                 const torch::Tensor& joint_translations) {
  const int64_t J = static_cast<int64_t>(parents.size());
  FSKIN_CHECK(J > 0, "forward_kinematics: zero joints");
  expect_shape(local_rotations, {-1, J, 3, 3}, "forward_kinematics: local_rotations");
  const int64_t B = local_rotations.size(0);
  torch::Tensor rest = rest_joints;
  if (rest.dim() == 2) rest = rest.unsqueeze(0).expand({B, J, 3});
  expect_shape(rest, {B, J, 3}, "forward_kinematics: rest_joints");
  rest = rest.to(local_rotations.dtype());
  torch::Tensor moved;
  if (joint_translations.defined()) {
    expect_shape(joint_translations, {B, J, 3}, "forward_kinematics: joint_translations");
    moved = joint_translations.to(local_rotations.dtype());
  }

  // Offsets from the parent joint in the rest pose; the root's is its position.
  std::vector<torch::Tensor> frames(J);
  for (int64_t j = 0; j < J; ++j) {
    const auto r = local_rotations.select(1, j);
    if (parents[j] < 0) {
      auto t = rest.select(1, j);
      if (root_translation.defined()) {
        expect_shape(root_translation, {B, 3}, "forward_kinematics: root_translation");
        t = t + root_translation.to(t.dtype());
      }
      if (moved.defined()) t = t + moved.select(1, j);
      frames[j] = make_transform(r, t);
    } else {
      FSKIN_CHECK(parents[j] < j, "forward_kinematics: parent of joint {} is {} (not topological)",
                  j, parents[j]);
      auto offset = rest.select(1, j) - rest.select(1, parents[j]);
      if (moved.defined()) offset = offset + moved.select(1, j);
      frames[j] = torch::matmul(frames[parents[j]], make_transform(r, offset));
    }
  }
  PosedSkeleton out;
  out.joint_frames = torch::stack(frames, 1);  // [B, J, 4, 4]
  out.joints = out.joint_frames.index({torch::indexing::Ellipsis, torch::indexing::Slice(0, 3), 3});
  // B_j = G_j [I | -rest_j]: the rest-pose point is first expressed in joint j's frame.
  const auto rot = out.joint_frames.index(
      {torch::indexing::Ellipsis, torch::indexing::Slice(0, 3), torch::indexing::Slice(0, 3)});
  const auto shift = torch::matmul(rot, rest.unsqueeze(-1)).squeeze(-1);
  out.bone_transforms = make_transform(rot, out.joints - shift);
  return out;
}

torch::Tensor relative_bone_transforms(const torch::Tensor& posed_bones,
                                       const torch::Tensor& canonical_bones) {
  return torch::matmul(posed_bones, invert_transforms(canonical_bones));
}

}  // namespace fskin
