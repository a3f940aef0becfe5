#include "fskin/body/smpl_skeleton.h"

#include <algorithm>

namespace fskin {

const std::vector<std::string>& smpl_joint_names() {
  static const std::vector<std::string> names = {
      "pelvis",     "left_hip",    "right_hip",    "spine1",      "left_knee",     "right_knee",
      "spine2",     "left_ankle",  "right_ankle",  "spine3",      "left_foot",     "right_foot",
      "neck",       "left_collar", "right_collar", "head",        "left_shoulder", "right_shoulder",
      "left_elbow", "right_elbow", "left_wrist",   "right_wrist", "left_hand",     "right_hand"};
  return names;
}

const std::vector<int64_t>& smpl_parents() {
  static const std::vector<int64_t> parents = {-1, 0, 0, 0,  1,  2,  3,  4,  5,  6,  7,  8,
                                               9,  9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21};
  return parents;
}

bool is_smpl_skeleton(const std::vector<std::string>& joint_names) {
  // SMPL-H and SMPL-X extend SMPL's first 22 body joints with hands (and a face).
  constexpr size_t kSmplBodyJoints = 22;
  const auto& smpl = smpl_joint_names();
  return joint_names.size() >= kSmplBodyJoints &&
         std::equal(smpl.begin(), smpl.begin() + kSmplBodyJoints, joint_names.begin());
}

}  // namespace fskin
