#pragma once
// The inverse of forward_kinematics for rigid bone transforms: local
// rotations and root translation from bone transforms B_j (rest -> posed),
// e.g. the skinning matrices of an imported glTF clip or of a learned avatar
// exported in its canonical pose.
#include <torch/types.h>

#include <vector>

namespace fskin {

struct RecoveredPose {
  torch::Tensor local_rotations;     // [T, J, 3] axis-angle, relative to the parent (forward_kinematics' input)
  torch::Tensor root_translation;    // [T, 3]
  torch::Tensor joint_translations;  // [T, J, 3] (forward_kinematics' input; the root's entry is 0)
  // Largest distance (metres) between a joint where `bones` put it and where
  // forward kinematics with the rotations and root translation alone puts
  // it: > 0 when the transforms move joints off their rest offsets (animated
  // non-root translations), which joint_translations then carries.
  double max_joint_drift = 0;
  // Largest |singular value - 1| of the bones' 3x3s: scale or shear, which
  // rigid joint transforms drop.
  double max_scale_deviation = 0;
};

// parents: topological order; rest_joints [J, 3]; bones [T, J, 4, 4]. Each
// bone's 3x3 is projected onto the nearest rotation Q_j (polar
// decomposition) before R_j = Q_parent^T Q_j; the root translation is
// B_0 rest_0 - rest_0; joint j's translation is what puts it where its bone
// puts it: Q_parent^T (p_j - p_parent) - (rest_j - rest_parent), with
// p_j = B_j rest_j. With the translations, forward kinematics reproduces every
// joint position exactly.
RecoveredPose pose_from_bone_transforms(const std::vector<int64_t>& parents, const torch::Tensor& rest_joints,
                                        const torch::Tensor& bones);

}  // namespace fskin
