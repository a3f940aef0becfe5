#include "data/lowpoly/clip_builder.h"

#include <torch/torch.h>

#include <Eigen/Geometry>

#include "fskin/core/error.h"

namespace fskin::procedural {

Mat3 rotation_x(double radians) { return Eigen::AngleAxisd(radians, Eigen::Vector3d::UnitX()).toRotationMatrix(); }
Mat3 rotation_y(double radians) { return Eigen::AngleAxisd(radians, Eigen::Vector3d::UnitY()).toRotationMatrix(); }
Mat3 rotation_z(double radians) { return Eigen::AngleAxisd(radians, Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

Mat3 mirrored(const Mat3& rotation, int axis) {
  Mat3 m = Mat3::Identity();
  m(axis, axis) = -1;
  return m * rotation * m;
}

PoseSet make_clips(const std::vector<std::string>& joint_names, const std::vector<ClipSpec>& clips) {
  const auto J = static_cast<int64_t>(joint_names.size());
  int64_t total = 0;
  PoseSet set;
  for (const auto& clip : clips) {
    FSKIN_CHECK(clip.frames > 0, "clip '{}' has no frames", clip.name);
    set.clip_names.push_back(clip.name);
    set.clip_starts.push_back(total);
    total += clip.frames;
  }
  set.poses = torch::zeros({total, J, 3});
  set.trans = torch::zeros({total, 3});
  set.joint_names = joint_names;
  auto* pose = set.poses.data_ptr<float>();
  auto* trans = set.trans.data_ptr<float>();
  int64_t n = 0;
  for (const auto& clip : clips)
    for (int f = 0; f < clip.frames; ++f, ++n) {
      ClipFrame frame(static_cast<int>(J));
      clip.pose(static_cast<double>(f) / clip.frames, frame);
      for (int64_t j = 0; j < J; ++j) {
        const Eigen::AngleAxisd aa(frame.rotations[j]);
        for (int a = 0; a < 3; ++a) pose[(n * J + j) * 3 + a] = static_cast<float>(aa.angle() * aa.axis()[a]);
      }
      for (int a = 0; a < 3; ++a) trans[3 * n + a] = static_cast<float>(frame.root_translation[a]);
    }
  return set;
}

}  // namespace fskin::procedural
