#pragma once
// Seeded pose generators for building datasets, after the papers' protocol
// (SNARF sec. 4.1): train on natural motions (DFaust-like), test on extreme
// poses outside the training distribution (PosePrior-like).
//
// Two kinds of skeleton have motions of their own, recognised by their joint
// names: SMPL's (smpl_skeleton.h; walks, arm swings, bends; leg raises,
// crossed arms, squats) and the built-in quadruped's (quadruped.h; walk, trot,
// sit, looking around; rearing, lying down, tail over the back). Any other
// skeleton takes its joint ranges from data, e.g. its own animation clips
// (ranges_of_poses): training poses are smooth motions inside them, OOD poses
// push joints beyond them. Ranges bound each axis-angle component.
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
using JointRanges = std::vector<JointRange>;  // one per joint

// "smpl" or "quadruped" for skeletons with built-in motions, "" otherwise.
std::string builtin_motions(const std::vector<std::string>& joint_names);

// The training ranges of a skeleton with built-in motions; for any other
// skeleton throws fskin::Error saying so and what to pass instead.
JointRanges training_ranges(const std::vector<std::string>& joint_names);

// Per joint and component, the [min, max] that the poses of `poses` span
// (`source` names it in errors): training ranges taken from a rig's own clips
// or from captured motion. Throws unless poses has >= 1 pose.
JointRanges ranges_of_poses(const PoseSet& poses, const std::string& source);

struct TrainingPoseOptions {
  int64_t sequences = 10;
  int64_t frames_per_sequence = 30;
  uint64_t seed = 0;
};

// Natural motions of a skeleton with built-in motions (training_ranges()
// throws for others): each sequence is one motion family with per-sequence
// amplitudes, speeds and phases and a little per-frame jitter; every
// component is clamped to the training ranges. Frames of one sequence are
// consecutive in the result.
PoseSet make_training_poses(const std::vector<std::string>& joint_names, const TrainingPoseOptions& options);
// Any skeleton: every joint oscillates smoothly inside `ranges` (one per
// joint) around a per-sequence posture, with per-joint phases.
PoseSet make_training_poses(const std::vector<std::string>& joint_names, const JointRanges& ranges,
                            const TrainingPoseOptions& options);

struct OodPoseOptions {
  int64_t count = 50;
  uint64_t seed = 1;
};

// Extreme poses of a skeleton with built-in motions: one or two extreme
// families on top of a moderate random pose. Every pose has at least one
// joint component at least kOodMargin outside its training range.
PoseSet make_ood_poses(const std::vector<std::string>& joint_names, const OodPoseOptions& options);
// Any skeleton: a moderate pose inside `ranges` with 1-3 joints that move in
// the ranges pushed kOodMargin to 1 rad beyond them.
PoseSet make_ood_poses(const std::vector<std::string>& joint_names, const JointRanges& ranges,
                       const OodPoseOptions& options);

// How far (radians) each OOD pose exceeds the training ranges, at least.
inline constexpr double kOodMargin = 0.3;

// The largest amount (radians, >= 0) by which any component of `pose` [J, 3]
// lies outside `ranges`.
double range_excess(const JointRanges& ranges, const torch::Tensor& pose);
// range_excess(training_ranges(joint_names), pose).
double training_range_excess(const std::vector<std::string>& joint_names, const torch::Tensor& pose);

}  // namespace fskin
