#pragma once
// Seeded pose generators for building datasets from any skeleton, after the
// papers' protocol (SNARF sec. 4.1): train on natural motions (DFaust-like),
// test on extreme poses outside the training distribution (PosePrior-like).
//
// Joint limits are looked up by SMPL joint name (T-pose rest, +Y up, +Z
// forward, +X to the body's left; docs/conventions.md). Joints with other
// names get a generic small range. Ranges bound each axis-angle component.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/data/pose_set.h"

namespace fskin {

// Axis-angle component bounds (radians) of one joint in the training set.
struct JointRange {
  std::array<double, 3> low{};
  std::array<double, 3> high{};
};

// The training range of a joint by name; generic +-0.25 rad for unknown names.
JointRange training_range(const std::string& joint_name);

struct TrainingPoseOptions {
  int64_t sequences = 10;
  int64_t frames_per_sequence = 30;
  uint64_t seed = 0;
};

// Natural motions: each sequence is a walk cycle, an arm swing, a bend or a
// mixed motion with per-sequence amplitudes, speeds and phases and a little
// per-frame jitter; every component is clamped to training_range(). Frames of
// one sequence are consecutive in the result.
PoseSet make_training_poses(const std::vector<std::string>& joint_names,
                            const TrainingPoseOptions& options);

struct OodPoseOptions {
  int64_t count = 50;
  uint64_t seed = 1;
};

// Extreme poses: each combines one or two of large leg raises, crossed arms,
// deep forward bends, arms overhead, squats, splits, torso twists and hands
// folded onto the body (self-contact) on top of a moderate random pose. Every
// pose has at least one joint component at least kOodMargin outside its
// training range. Skeletons without SMPL names get random joints pushed to
// 2-3x the generic range instead.
PoseSet make_ood_poses(const std::vector<std::string>& joint_names,
                       const OodPoseOptions& options);

// How far (radians) each OOD pose exceeds the training ranges, at least.
inline constexpr double kOodMargin = 0.3;

// The largest amount (radians, >= 0) by which any component of `pose` [J, 3]
// lies outside the training ranges of `joint_names`.
double training_range_excess(const std::vector<std::string>& joint_names,
                             const torch::Tensor& pose);

}  // namespace fskin
