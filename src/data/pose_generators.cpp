#include "fskin/data/pose_generators.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "data/motions/motion_library.h"
#include "fskin/body/quadruped.h"
#include "fskin/body/smpl_skeleton.h"
#include "fskin/core/error.h"
#include "fskin/data/random.h"

namespace fskin {
namespace {

using motions::MotionLibrary;
using motions::PoseBuilder;

// The library of a skeleton with built-in motions; throws for others.
MotionLibrary builtin_library(const std::vector<std::string>& names) {
  FSKIN_CHECK(!names.empty(), "pose generators: the skeleton has no joints");
  const std::string kind = builtin_motions(names);
  if (kind == "smpl") return motions::smpl_motions(names);
  if (kind == "quadruped") return motions::quadruped_motions(names);
  std::string sample;
  for (size_t j = 0; j < std::min<size_t>(names.size(), 4); ++j) sample += (j ? ", " : "") + names[j];
  fail("fskin has no built-in motions for this skeleton ({} joints: {}{}): it knows SMPL's and the built-in "
       "quadruped's joint names. Take the joint ranges from the character's own clips or a motion file "
       "instead (fskin poses train|ood --ranges-from POSES.npz)",
       names.size(), sample, names.size() > 4 ? ", ..." : "");
}

// A library for any skeleton: its ranges, every joint oscillating.
MotionLibrary range_library(const std::vector<std::string>& names, const JointRanges& ranges) {
  FSKIN_CHECK(!names.empty(), "pose generators: the skeleton has no joints");
  FSKIN_CHECK(ranges.size() == names.size(), "pose generators: {} joint ranges for a skeleton of {} joints",
              ranges.size(), names.size());
  for (size_t j = 0; j < ranges.size(); ++j)
    for (int a = 0; a < 3; ++a)
      FSKIN_CHECK(std::isfinite(ranges[j].low[a]) && std::isfinite(ranges[j].high[a]) &&
                      ranges[j].low[a] <= ranges[j].high[a],
                  "pose generators: joint '{}' has an empty or non-finite range on axis {}", names[j], a);
  MotionLibrary library;
  library.ranges = ranges;
  library.oscillate.assign(names.size(), true);
  return library;
}

PoseSet make_pose_set(const std::vector<std::string>& names, std::vector<float> values, int64_t count) {
  PoseSet set;
  const auto J = static_cast<int64_t>(names.size());
  set.poses = torch::from_blob(values.data(), {count, J, 3}, torch::kFloat32).clone();
  set.trans = torch::zeros({count, 3});
  set.joint_names = names;
  return set;
}

PoseSet training_poses(const std::vector<std::string>& names, const MotionLibrary& library,
                       const TrainingPoseOptions& options) {
  FSKIN_CHECK(options.sequences > 0 && options.frames_per_sequence > 0,
              "make_training_poses: sequences ({}) and frames per sequence ({}) must be positive",
              options.sequences, options.frames_per_sequence);
  const int64_t count = options.sequences * options.frames_per_sequence;
  const size_t J = names.size();
  std::vector<float> values(count * J * 3);
  for (int64_t s = 0; s < options.sequences; ++s) {
    Rng rng = Rng::for_item(options.seed, static_cast<uint64_t>(s));
    const int family = static_cast<int>(rng.index(library.families));
    const double amp = rng.uniform(0.5, 1.0);
    const double speed = rng.uniform(0.15, 0.35);  // radians of phase per frame
    const double phase0 = rng.uniform(0.0, 2.0 * M_PI);
    PoseBuilder base(names, library.ranges);
    base.randomize(rng, 0.15);  // a per-sequence posture around the range centres
    std::vector<double> oscillation_phases(3 * J);
    for (double& p : oscillation_phases) p = rng.uniform(0.0, 2.0 * M_PI);
    for (int64_t f = 0; f < options.frames_per_sequence; ++f) {
      PoseBuilder pose = base;
      const double phase = phase0 + speed * static_cast<double>(f);
      if (library.natural) library.natural(family, phase, amp, pose);
      for (size_t j = 0; j < J; ++j)
        if (library.oscillate[j])
          for (int a = 0; a < 3; ++a) pose.add(j, a, 0.8 * pose.half(j, a) * std::sin(phase + oscillation_phases[3 * j + a]));
      pose.jitter(rng, 0.02);
      pose.clamp_to_ranges();
      pose.write(values.data() + (s * options.frames_per_sequence + f) * J * 3);
    }
  }
  return make_pose_set(names, std::move(values), count);
}

PoseSet ood_poses(const std::vector<std::string>& names, const MotionLibrary& library, const OodPoseOptions& options) {
  FSKIN_CHECK(options.count > 0, "make_ood_poses: count must be positive, got {}", options.count);
  const size_t J = names.size();
  // Joints that move inside their ranges; pushing them beyond is what "out of
  // distribution" means for a skeleton known only by its ranges.
  std::vector<size_t> moving;
  for (size_t j = 0; j < J; ++j)
    for (int a = 0; a < 3; ++a)
      if (library.ranges[j].high[a] - library.ranges[j].low[a] > 1e-3) {
        moving.push_back(j);
        break;
      }
  if (moving.empty())
    for (size_t j = 0; j < J; ++j) moving.push_back(j);
  std::vector<float> values(options.count * J * 3);
  for (int64_t i = 0; i < options.count; ++i) {
    Rng rng = Rng::for_item(options.seed, static_cast<uint64_t>(i));
    PoseBuilder pose(names, library.ranges);
    pose.randomize(rng, 0.5);
    const auto templates = library.ood_templates ? library.ood_templates(pose) : std::vector<motions::Template>{};
    if (templates.empty()) {
      const int64_t pushed = 1 + rng.index(3);
      for (int64_t k = 0; k < pushed; ++k) {
        const size_t j = moving[rng.index(static_cast<int64_t>(moving.size()))];
        const int a = static_cast<int>(rng.index(3));
        const double beyond = rng.uniform(kOodMargin + 0.05, 1.0);
        const auto& range = library.ranges[j];
        pose.set(j, a, rng.uniform() < 0.5 ? range.low[a] - beyond : range.high[a] + beyond);
      }
    } else {
      const auto first = rng.index(static_cast<int64_t>(templates.size()));
      templates[first](rng, pose);
      if (templates.size() > 1 && rng.uniform() < 0.5) {
        // A second, different family (later families may override shared joints).
        auto second = rng.index(static_cast<int64_t>(templates.size()) - 1);
        if (second >= first) ++second;
        templates[second](rng, pose);
      }
    }
    pose.write(values.data() + i * J * 3);
  }
  return make_pose_set(names, std::move(values), options.count);
}

}  // namespace

std::string builtin_motions(const std::vector<std::string>& joint_names) {
  if (is_smpl_skeleton(joint_names)) return "smpl";
  if (is_builtin_quadruped(joint_names)) return "quadruped";
  return "";
}

JointRanges training_ranges(const std::vector<std::string>& joint_names) {
  return builtin_library(joint_names).ranges;
}

JointRanges ranges_of_poses(const PoseSet& poses, const std::string& source) {
  poses.validate(source);
  FSKIN_CHECK(poses.size() >= 1, "{}: no poses to take joint ranges from", source);
  const auto p = poses.poses.to(torch::kFloat64);
  const auto low = std::get<0>(p.min(0)).contiguous(), high = std::get<0>(p.max(0)).contiguous();  // [J, 3]
  JointRanges ranges(static_cast<size_t>(poses.num_joints()));
  for (size_t j = 0; j < ranges.size(); ++j)
    for (int a = 0; a < 3; ++a) {
      ranges[j].low[a] = low.data_ptr<double>()[3 * j + a];
      ranges[j].high[a] = high.data_ptr<double>()[3 * j + a];
    }
  return ranges;
}

PoseSet make_training_poses(const std::vector<std::string>& joint_names, const TrainingPoseOptions& options) {
  return training_poses(joint_names, builtin_library(joint_names), options);
}

PoseSet make_training_poses(const std::vector<std::string>& joint_names, const JointRanges& ranges,
                            const TrainingPoseOptions& options) {
  return training_poses(joint_names, range_library(joint_names, ranges), options);
}

PoseSet make_ood_poses(const std::vector<std::string>& joint_names, const OodPoseOptions& options) {
  return ood_poses(joint_names, builtin_library(joint_names), options);
}

PoseSet make_ood_poses(const std::vector<std::string>& joint_names, const JointRanges& ranges,
                       const OodPoseOptions& options) {
  return ood_poses(joint_names, range_library(joint_names, ranges), options);
}

double range_excess(const JointRanges& ranges, const torch::Tensor& pose) {
  FSKIN_CHECK(pose.dim() == 2 && pose.size(0) == static_cast<int64_t>(ranges.size()) && pose.size(1) == 3,
              "range_excess: pose must be [{}, 3]", ranges.size());
  const auto p = pose.to(torch::kFloat64).contiguous();
  const double* v = p.data_ptr<double>();
  double excess = 0.0;
  for (size_t j = 0; j < ranges.size(); ++j)
    for (int a = 0; a < 3; ++a) {
      const double x = v[3 * j + a];
      excess = std::max({excess, ranges[j].low[a] - x, x - ranges[j].high[a]});
    }
  return excess;
}

double training_range_excess(const std::vector<std::string>& joint_names, const torch::Tensor& pose) {
  return range_excess(training_ranges(joint_names), pose);
}

}  // namespace fskin
