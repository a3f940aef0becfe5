#pragma once
// SMPL's kinematic tree, for the SMPL-only branches of fskin: the papers'
// Da-pose canonical, their 9 start bones and the human pose generators apply
// only to skeletons that is_smpl_skeleton() recognises; every other skeleton
// gets defaults derived from its own data (docs/conventions.md, "Any
// skeleton").
#include <cstdint>
#include <string>
#include <vector>

namespace fskin {

// SMPL's 24 joint names and parents, in SMPL order.
const std::vector<std::string>& smpl_joint_names();
const std::vector<int64_t>& smpl_parents();

// Whether a skeleton's first 22 joints carry SMPL's body-joint names in
// SMPL's order (SMPL, SMPL-H, SMPL-X and fskin's built-in character).
bool is_smpl_skeleton(const std::vector<std::string>& joint_names);

}  // namespace fskin
