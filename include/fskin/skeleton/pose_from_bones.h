#pragma once
// The inverse of forward_kinematics for rigid bone transforms: local
// rotations and root translation from bone transforms B_j (rest -> posed),
// e.g. the skinning matrices of an imported glTF clip or of a learned avatar
// exported in its canonical pose.
#include <torch/types.h>

#include <vector>

namespace fskin {

struct RecoveredPose {
  torch::Tensor local_rotations;   // [T, J, 3] axis-angle, relative to the parent (forward_kinematics' input)
  torch::Tensor root_translation;  // [T, 3]
  // Largest distance (metres) between a joint where `bones` put it and where
  // forward kinematics with the recovered pose puts it: > 0 when the
  // transforms move joints along their bones (animated non-root translations)
  // or carry scale, which a rotations-only pose cannot express.
  double max_joint_drift = 0;
};

// parents: topological order; rest_joints [J, 3]; bones [T, J, 4, 4]. Each
// bone's 3x3 is projected onto the nearest rotation (polar decomposition)
// before R_j = Q_parent^T Q_j; the root translation is B_0 rest_0 - rest_0.
RecoveredPose pose_from_bone_transforms(const std::vector<int64_t>& parents, const torch::Tensor& rest_joints,
                                        const torch::Tensor& bones);

}  // namespace fskin
