#pragma once
// Forward kinematics: per-joint local rotations + root translation -> world
// joint frames and bone transforms B_j (4x4, canonical -> posed, column
// vectors: x_posed = B_j x_canonical). Batched over B, differentiable.
#include <torch/types.h>

#include <vector>

namespace fskin {

struct PosedSkeleton {
  torch::Tensor joint_frames;     // [B, J, 4, 4] world frame of each joint (rotation, position)
  torch::Tensor bone_transforms;  // [B, J, 4, 4] rest -> posed: B_j = G_j * [I | -rest_j]
  torch::Tensor joints;           // [B, J, 3] posed joint positions
};

// parents: topological order (parents[0] == -1).
// rest_joints: [J, 3] or [B, J, 3] joint positions in the rest pose.
// local_rotations: [B, J, 3, 3] rotation of each joint relative to its parent.
// root_translation: [B, 3], or undefined for none.
// joint_translations: [B, J, 3] or undefined: each joint's displacement from
// its rest offset, in its parent's frame (rigs that animate the translations
// of non-root joints: stretchy spines, facial rigs, props). The root's entry
// adds to root_translation.
PosedSkeleton forward_kinematics(const std::vector<int64_t>& parents,
                                 const torch::Tensor& rest_joints,
                                 const torch::Tensor& local_rotations,
                                 const torch::Tensor& root_translation = {},
                                 const torch::Tensor& joint_translations = {});

// Transforms from an arbitrary canonical pose to the target pose:
// posed_from_canonical = posed_bones @ inverse(canonical_bones), both [..., J, 4, 4].
// The deformers take these when the canonical pose is not the rest pose (Da-pose).
torch::Tensor relative_bone_transforms(const torch::Tensor& posed_bones,
                                       const torch::Tensor& canonical_bones);

}  // namespace fskin
