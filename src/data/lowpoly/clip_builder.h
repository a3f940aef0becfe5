#pragma once
// Animation clips for fskin's procedural characters, written the way an
// animator keys them: per frame, each joint's local rotation (relative to its
// parent, in the rest pose's axes) and the root's translation. Internal to src/data/lowpoly.
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "fskin/data/pose_set.h"

namespace fskin::procedural {

using Mat3 = Eigen::Matrix3d;

Mat3 rotation_x(double radians);
Mat3 rotation_y(double radians);
Mat3 rotation_z(double radians);
// The rotation mirrored across the plane normal to `axis` (0, 1, 2): what the
// other side's joint does when a character moves symmetrically.
Mat3 mirrored(const Mat3& rotation, int axis);

struct ClipFrame {
  explicit ClipFrame(int num_joints) : rotations(num_joints, Mat3::Identity()) {}
  std::vector<Mat3> rotations;
  Eigen::Vector3d root_translation = Eigen::Vector3d::Zero();
};

struct ClipSpec {
  std::string name;
  int frames = 0;
  // Fills one frame at `phase` in [0, 1): the clip loops.
  std::function<void(double phase, ClipFrame& frame)> pose;
};

// The clips back to back as axis-angle poses with clip names and starts.
PoseSet make_clips(const std::vector<std::string>& joint_names, const std::vector<ClipSpec>& clips);

}  // namespace fskin::procedural
