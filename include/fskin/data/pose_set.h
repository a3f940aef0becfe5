#pragma once
// A sequence of body poses: the .npz pose file format of fskin.
//   poses       (N, J, 3) float  per-joint axis-angle, radians, relative to the parent
//   trans       (N, 3)    float  optional root translation, metres
//   joint_translations (N, J, 3) float  optional: each joint's displacement from its
//                                  rest offset, in its parent's frame, metres
//                                  (forward_kinematics.h; imported clips that
//                                  animate non-root translations)
//   joint_names (J,)      '<U'   optional; checked against the model when present
//   clip_names  (C,)      '<U'   optional: named clips back to back (imported animations)
//   clip_starts (C,)      int64  first pose of each clip, increasing from 0
#include <torch/types.h>

#include <string>
#include <vector>

namespace fskin {

struct PoseSet {
  torch::Tensor poses;                  // [N, J, 3] float32
  torch::Tensor trans;                  // [N, 3] float32 (zeros when the file has none)
  std::vector<std::string> joint_names; // may be empty
  std::vector<std::string> clip_names;  // may be empty; else one per clip
  std::vector<int64_t> clip_starts;     // as many as clip_names
  torch::Tensor joint_translations;     // [N, J, 3] float32, or undefined (none)

  int64_t size() const { return poses.defined() ? poses.size(0) : 0; }
  int64_t num_joints() const { return poses.defined() ? poses.size(1) : 0; }

  // Poses [first, last) with their translations; no clips.
  PoseSet slice(int64_t first, int64_t last) const;

  static PoseSet load(const std::string& path);
  void save(const std::string& path) const;
  // Throws fskin::Error (prefixed with `context`) on wrong shapes, NaN/inf, or
  // joint names that differ from `expected_names` (when both are non-empty).
  void validate(const std::string& context, int64_t expected_joints = -1,
                const std::vector<std::string>& expected_names = {}) const;
};

}  // namespace fskin
