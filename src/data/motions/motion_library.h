#pragma once
// The motions the pose generators draw from (pose_generators.h), per kind of
// skeleton: joint ranges, natural motion families and out-of-distribution
// templates. Internal to src/data.
#include <algorithm>
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "fskin/data/pose_generators.h"
#include "fskin/data/random.h"

namespace fskin::motions {

enum Axis { kX = 0, kY = 1, kZ = 2 };

// A [J, 3] pose under construction, addressed by joint name.
class PoseBuilder {
 public:
  PoseBuilder(const std::vector<std::string>& names, const JointRanges& ranges)
      : names_(names), ranges_(ranges), values_(names.size(), {0.0, 0.0, 0.0}) {}
  int64_t find(const std::string& name) const {
    const auto it = std::find(names_.begin(), names_.end(), name);
    return it == names_.end() ? -1 : static_cast<int64_t>(it - names_.begin());
  }
  bool has(const std::string& name) const { return find(name) >= 0; }
  // Adds `value` to a component; ignores joints the skeleton lacks.
  void add(const std::string& name, int axis, double value) {
    const int64_t j = find(name);
    if (j >= 0) values_[j][axis] += value;
  }
  void set(const std::string& name, int axis, double value) {
    const int64_t j = find(name);
    if (j >= 0) values_[j][axis] = value;
  }
  void add(size_t joint, int axis, double value) { values_[joint][axis] += value; }
  void set(size_t joint, int axis, double value) { values_[joint][axis] = value; }
  // Uniform in [mid - s * half, mid + s * half] of each range.
  void randomize(Rng& rng, double scale) {
    for (size_t j = 0; j < values_.size(); ++j)
      for (int a = 0; a < 3; ++a) values_[j][a] = mid(j, a) + scale * half(j, a) * rng.uniform(-1.0, 1.0);
  }
  void jitter(Rng& rng, double fraction) {
    for (size_t j = 0; j < values_.size(); ++j)
      for (int a = 0; a < 3; ++a) values_[j][a] += fraction * 2 * half(j, a) * rng.normal();
  }
  void clamp_to_ranges() {
    for (size_t j = 0; j < values_.size(); ++j)
      for (int a = 0; a < 3; ++a) values_[j][a] = std::clamp(values_[j][a], ranges_[j].low[a], ranges_[j].high[a]);
  }
  double mid(size_t j, int a) const { return 0.5 * (ranges_[j].low[a] + ranges_[j].high[a]); }
  double half(size_t j, int a) const { return 0.5 * (ranges_[j].high[a] - ranges_[j].low[a]); }
  const JointRange& range(size_t j) const { return ranges_[j]; }
  void write(float* out) const {
    for (const auto& v : values_)
      for (double c : v) *out++ = static_cast<float>(c);
  }
  size_t size() const { return values_.size(); }

 private:
  std::vector<std::string> names_;
  JointRanges ranges_;
  std::vector<std::array<double, 3>> values_;
};

using Template = std::function<void(Rng&, PoseBuilder&)>;

struct MotionLibrary {
  JointRanges ranges;  // per joint: the training ranges
  // Natural motion families (0 .. families - 1) at phase `phase` (radians)
  // with amplitude `amp` in [0.5, 1]; none: only the oscillation below.
  int families = 1;
  std::function<void(int family, double phase, double amp, PoseBuilder&)> natural;
  // Joints that oscillate smoothly inside their ranges in every family (the
  // joints no named motion moves).
  std::vector<bool> oscillate;
  // Extreme pose families for a pose (empty: push random joints beyond their ranges).
  std::function<std::vector<Template>(const PoseBuilder&)> ood_templates;
};

// SMPL skeletons (is_smpl_skeleton): walks, arm swings, bends, twists; leg
// raises, crossed arms, squats, splits. Joints beyond SMPL's 24 (SMPL-H/X
// hands) get a generic +-0.25 rad range and oscillate.
MotionLibrary smpl_motions(const std::vector<std::string>& names);
// The built-in quadruped (quadruped.h): walk, trot, sit, head and tail
// motion; rearing, lying down, tail over the back, head turned back, gallop
// stretch, a hind leg lifted, a side bend.
MotionLibrary quadruped_motions(const std::vector<std::string>& names);

}  // namespace fskin::motions
