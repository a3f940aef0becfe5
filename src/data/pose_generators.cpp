#include "fskin/data/pose_generators.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

#include "fskin/core/error.h"
#include "fskin/data/random.h"

namespace fskin {
namespace {

enum Axis { kX = 0, kY = 1, kZ = 2 };
constexpr double kGenericLimit = 0.25;

// Training ranges (radians) of SMPL joints, T-pose rest. Signs follow from the
// axes: a rotation about +X swings a downward leg backwards (so a forward leg
// swing is negative) and bends the upright torso forwards; a rotation about +Z
// raises the left arm (+X) and lowers the right one; a rotation about +Y swings
// the left arm backwards and the right arm forwards. The ranges cover walking,
// arm swings and moderate bends, as in DFaust.
const std::map<std::string, JointRange>& smpl_training_ranges() {
  static const std::map<std::string, JointRange> ranges = {
      {"pelvis", {{-0.15, -0.4, -0.1}, {0.15, 0.4, 0.1}}},
      {"left_hip", {{-0.7, -0.25, -0.1}, {0.4, 0.25, 0.35}}},
      {"right_hip", {{-0.7, -0.25, -0.35}, {0.4, 0.25, 0.1}}},
      {"spine1", {{-0.15, -0.2, -0.15}, {0.35, 0.2, 0.15}}},
      {"spine2", {{-0.15, -0.2, -0.15}, {0.35, 0.2, 0.15}}},
      {"spine3", {{-0.15, -0.2, -0.15}, {0.35, 0.2, 0.15}}},
      {"left_knee", {{0.0, -0.1, -0.05}, {1.2, 0.1, 0.05}}},
      {"right_knee", {{0.0, -0.1, -0.05}, {1.2, 0.1, 0.05}}},
      {"left_ankle", {{-0.35, -0.15, -0.15}, {0.35, 0.15, 0.15}}},
      {"right_ankle", {{-0.35, -0.15, -0.15}, {0.35, 0.15, 0.15}}},
      {"left_foot", {{-0.2, -0.1, -0.1}, {0.2, 0.1, 0.1}}},
      {"right_foot", {{-0.2, -0.1, -0.1}, {0.2, 0.1, 0.1}}},
      {"neck", {{-0.2, -0.3, -0.15}, {0.3, 0.3, 0.15}}},
      {"head", {{-0.2, -0.3, -0.15}, {0.3, 0.3, 0.15}}},
      {"left_collar", {{-0.1, -0.15, -0.1}, {0.1, 0.15, 0.2}}},
      {"right_collar", {{-0.1, -0.15, -0.2}, {0.1, 0.15, 0.1}}},
      {"left_shoulder", {{-0.3, -0.6, -1.2}, {0.3, 0.5, 0.3}}},
      {"right_shoulder", {{-0.3, -0.5, -0.3}, {0.3, 0.6, 1.2}}},
      {"left_elbow", {{-0.1, -1.2, -0.1}, {0.1, 0.0, 0.1}}},
      {"right_elbow", {{-0.1, 0.0, -0.1}, {0.1, 1.2, 0.1}}},
      {"left_wrist", {{-0.4, -0.3, -0.4}, {0.4, 0.3, 0.4}}},
      {"right_wrist", {{-0.4, -0.3, -0.4}, {0.4, 0.3, 0.4}}},
      {"left_hand", {{-0.2, -0.2, -0.2}, {0.2, 0.2, 0.2}}},
      {"right_hand", {{-0.2, -0.2, -0.2}, {0.2, 0.2, 0.2}}},
  };
  return ranges;
}

// A [J, 3] pose under construction, addressed by joint name.
class PoseBuilder {
 public:
  explicit PoseBuilder(const std::vector<std::string>& names) : names_(names) {
    for (const auto& name : names) ranges_.push_back(training_range(name));
    values_.assign(names.size(), {0.0, 0.0, 0.0});
  }
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
  // Uniform in [mid - s * half, mid + s * half] of each training range.
  void randomize(Rng& rng, double scale) {
    for (size_t j = 0; j < values_.size(); ++j)
      for (int a = 0; a < 3; ++a) {
        const double mid = 0.5 * (ranges_[j].low[a] + ranges_[j].high[a]);
        const double half = 0.5 * (ranges_[j].high[a] - ranges_[j].low[a]);
        values_[j][a] = mid + scale * half * rng.uniform(-1.0, 1.0);
      }
  }
  void jitter(Rng& rng, double fraction) {
    for (size_t j = 0; j < values_.size(); ++j)
      for (int a = 0; a < 3; ++a)
        values_[j][a] += fraction * (ranges_[j].high[a] - ranges_[j].low[a]) * rng.normal();
  }
  void clamp_to_training() {
    for (size_t j = 0; j < values_.size(); ++j)
      for (int a = 0; a < 3; ++a)
        values_[j][a] = std::clamp(values_[j][a], ranges_[j].low[a], ranges_[j].high[a]);
  }
  void write(float* out) const {
    for (const auto& v : values_)
      for (double c : v) *out++ = static_cast<float>(c);
  }
  size_t size() const { return values_.size(); }

 private:
  std::vector<std::string> names_;
  std::vector<JointRange> ranges_;
  std::vector<std::array<double, 3>> values_;
};

// Side-dependent sign: mirror images of left-side motions on the right.
double mirror(const std::string& side) { return side == "left" ? 1.0 : -1.0; }

// One frame of a natural motion at phase `phase` (radians) with amplitude
// `amp` in [0.5, 1]: the motion families of the training set.
void natural_motion(int family, double phase, double amp, PoseBuilder& pose) {
  const double s = std::sin(phase), c = std::cos(phase);
  switch (family) {
    case 0:  // walk cycle: legs in antiphase, arms against the legs
      pose.add("left_hip", kX, -0.5 * amp * s);
      pose.add("right_hip", kX, 0.5 * amp * s);
      pose.add("left_knee", kX, 0.9 * amp * std::max(0.0, -c));
      pose.add("right_knee", kX, 0.9 * amp * std::max(0.0, c));
      pose.add("left_ankle", kX, 0.2 * amp * c);
      pose.add("right_ankle", kX, -0.2 * amp * c);
      pose.add("left_shoulder", kZ, -1.1);  // arms hang down while walking
      pose.add("right_shoulder", kZ, 1.1);
      pose.add("left_shoulder", kY, 0.4 * amp * s);
      pose.add("right_shoulder", kY, 0.4 * amp * s);
      pose.add("left_elbow", kY, -0.3 * amp * (1 + s));
      pose.add("right_elbow", kY, 0.3 * amp * (1 - s));
      pose.add("spine1", kY, 0.1 * amp * s);
      break;
    case 1:  // arm swing: both arms up and down and to the front and back
      for (const std::string side : {"left", "right"}) {
        pose.add(side + "_shoulder", kZ, mirror(side) * (-0.45 + 0.75 * amp * s));
        pose.add(side + "_shoulder", kY, -mirror(side) * 0.4 * amp * c);
        pose.add(side + "_elbow", kY, -mirror(side) * 0.6 * amp * (1 + c));
      }
      break;
    case 2: {  // forward bend and back, knees giving a little
      const double bend = 0.5 * amp * (1 - c);
      for (const char* spine : {"spine1", "spine2", "spine3"}) pose.add(spine, kX, 0.33 * bend);
      pose.add("neck", kX, 0.2 * bend);
      pose.add("left_hip", kX, -0.6 * bend);
      pose.add("right_hip", kX, -0.6 * bend);
      pose.add("left_knee", kX, 0.4 * bend);
      pose.add("right_knee", kX, 0.4 * bend);
      pose.add("left_shoulder", kZ, -0.8 * bend);
      pose.add("right_shoulder", kZ, 0.8 * bend);
      break;
    }
    default:  // side bend with torso twist and a head turn
      for (const char* spine : {"spine1", "spine2", "spine3"}) {
        pose.add(spine, kZ, 0.12 * amp * s);
        pose.add(spine, kY, 0.15 * amp * c);
      }
      pose.add("head", kY, 0.25 * amp * s);
      pose.add("left_hip", kZ, 0.2 * amp * std::max(0.0, s));
      pose.add("right_hip", kZ, -0.2 * amp * std::max(0.0, -s));
      break;
  }
}

// Generic joints (names unknown): a smooth oscillation inside the range.
void generic_motion(const std::vector<std::string>& names, const std::vector<double>& phases,
                    double t, PoseBuilder& pose) {
  const auto& smpl = smpl_training_ranges();
  for (size_t j = 0; j < names.size(); ++j) {
    if (smpl.count(names[j])) continue;
    for (int a = 0; a < 3; ++a)
      pose.add(names[j], a, 0.8 * kGenericLimit * std::sin(t + phases[3 * j + a]));
  }
}

using Template = std::function<void(Rng&, PoseBuilder&)>;

// Extreme pose families (values far outside smpl_training_ranges()).
std::vector<Template> ood_templates(const PoseBuilder& pose) {
  std::vector<Template> out;
  const auto side_of = [](Rng& rng) { return rng.uniform() < 0.5 ? std::string("left") : "right"; };
  if (pose.has("left_hip") && pose.has("right_hip")) {
    out.push_back([=](Rng& rng, PoseBuilder& p) {  // large leg raise, front or side
      const std::string side = side_of(rng);
      if (rng.uniform() < 0.6) p.set(side + "_hip", kX, -rng.uniform(1.5, 2.0));
      else p.set(side + "_hip", kZ, mirror(side) * rng.uniform(1.1, 1.5));
      p.set(side + "_knee", kX, rng.uniform(0.0, 0.4));
    });
    out.push_back([](Rng& rng, PoseBuilder& p) {  // split
      p.set("left_hip", kZ, rng.uniform(0.8, 1.2));
      p.set("right_hip", kZ, -rng.uniform(0.8, 1.2));
    });
  }
  if (pose.has("left_hip") && pose.has("left_knee") && pose.has("right_knee"))
    out.push_back([](Rng& rng, PoseBuilder& p) {  // deep squat: thighs against the belly
      const double hip = rng.uniform(1.5, 1.9), knee = rng.uniform(2.0, 2.4);
      for (const std::string side : {"left", "right"}) {
        p.set(side + "_hip", kX, -hip);
        p.set(side + "_knee", kX, knee);
      }
      p.set("spine1", kX, rng.uniform(0.2, 0.35));
    });
  if (pose.has("left_shoulder") && pose.has("left_elbow"))
    out.push_back([](Rng& rng, PoseBuilder& p) {  // crossed arms (self-contact)
      for (const std::string side : {"left", "right"}) {
        p.set(side + "_shoulder", kZ, -mirror(side) * rng.uniform(0.9, 1.3));
        p.set(side + "_shoulder", kY, -mirror(side) * rng.uniform(1.2, 1.6));
        p.set(side + "_elbow", kY, -mirror(side) * rng.uniform(1.8, 2.3));
      }
    });
  if (pose.has("left_shoulder"))
    out.push_back([](Rng& rng, PoseBuilder& p) {  // arms overhead
      p.set("left_shoulder", kZ, rng.uniform(1.2, 1.5));
      p.set("right_shoulder", kZ, -rng.uniform(1.2, 1.5));
    });
  if (pose.has("left_elbow"))
    out.push_back([=](Rng& rng, PoseBuilder& p) {  // forearm folded onto the upper arm
      const std::string side = side_of(rng);
      p.set(side + "_shoulder", kZ, mirror(side) * rng.uniform(-0.2, 0.6));
      p.set(side + "_elbow", kY, -mirror(side) * rng.uniform(2.2, 2.6));
    });
  if (pose.has("spine1") && pose.has("spine2"))
    out.push_back([](Rng& rng, PoseBuilder& p) {  // deep forward bend
      for (const char* spine : {"spine1", "spine2", "spine3"}) p.set(spine, kX, rng.uniform(0.7, 0.9));
    });
  if (pose.has("spine1") && pose.has("spine2"))
    out.push_back([](Rng& rng, PoseBuilder& p) {  // torso twist
      const double sign = rng.uniform() < 0.5 ? -1.0 : 1.0;
      for (const char* spine : {"spine1", "spine2", "spine3"}) p.set(spine, kY, sign * rng.uniform(0.5, 0.7));
    });
  return out;
}

PoseSet make_pose_set(const std::vector<std::string>& names, std::vector<float> values,
                      int64_t count) {
  PoseSet set;
  const auto J = static_cast<int64_t>(names.size());
  set.poses = torch::from_blob(values.data(), {count, J, 3}, torch::kFloat32).clone();
  set.trans = torch::zeros({count, 3});
  set.joint_names = names;
  return set;
}

}  // namespace

JointRange training_range(const std::string& joint_name) {
  const auto& ranges = smpl_training_ranges();
  const auto it = ranges.find(joint_name);
  if (it != ranges.end()) return it->second;
  JointRange generic;
  generic.low.fill(-kGenericLimit);
  generic.high.fill(kGenericLimit);
  return generic;
}

PoseSet make_training_poses(const std::vector<std::string>& joint_names,
                            const TrainingPoseOptions& options) {
  FSKIN_CHECK(!joint_names.empty(), "make_training_poses: the skeleton has no joints");
  FSKIN_CHECK(options.sequences > 0 && options.frames_per_sequence > 0,
              "make_training_poses: sequences ({}) and frames per sequence ({}) must be positive",
              options.sequences, options.frames_per_sequence);
  const int64_t count = options.sequences * options.frames_per_sequence;
  const size_t J = joint_names.size();
  std::vector<float> values(count * J * 3);
  for (int64_t s = 0; s < options.sequences; ++s) {
    Rng rng = Rng::for_item(options.seed, static_cast<uint64_t>(s));
    const int family = static_cast<int>(rng.index(4));
    const double amp = rng.uniform(0.5, 1.0);
    const double speed = rng.uniform(0.15, 0.35);  // radians of phase per frame
    const double phase0 = rng.uniform(0.0, 2.0 * M_PI);
    PoseBuilder base(joint_names);
    base.randomize(rng, 0.15);  // a per-sequence posture around the range centres
    std::vector<double> generic_phases(3 * J);
    for (double& p : generic_phases) p = rng.uniform(0.0, 2.0 * M_PI);
    for (int64_t f = 0; f < options.frames_per_sequence; ++f) {
      PoseBuilder pose = base;
      const double phase = phase0 + speed * static_cast<double>(f);
      natural_motion(family, phase, amp, pose);
      generic_motion(joint_names, generic_phases, phase, pose);
      pose.jitter(rng, 0.02);
      pose.clamp_to_training();
      pose.write(values.data() + (s * options.frames_per_sequence + f) * J * 3);
    }
  }
  return make_pose_set(joint_names, std::move(values), count);
}

PoseSet make_ood_poses(const std::vector<std::string>& joint_names,
                       const OodPoseOptions& options) {
  FSKIN_CHECK(!joint_names.empty(), "make_ood_poses: the skeleton has no joints");
  FSKIN_CHECK(options.count > 0, "make_ood_poses: count must be positive, got {}", options.count);
  const size_t J = joint_names.size();
  std::vector<float> values(options.count * J * 3);
  for (int64_t i = 0; i < options.count; ++i) {
    Rng rng = Rng::for_item(options.seed, static_cast<uint64_t>(i));
    PoseBuilder pose(joint_names);
    pose.randomize(rng, 0.5);
    const auto templates = ood_templates(pose);
    if (templates.empty()) {
      // No SMPL joints: push 1-3 random joints to 2-3x the generic range.
      const int64_t pushed = 1 + rng.index(3);
      for (int64_t k = 0; k < pushed; ++k) {
        const int64_t j = rng.index(static_cast<int64_t>(J));
        const double sign = rng.uniform() < 0.5 ? -1.0 : 1.0;
        pose.set(joint_names[j], static_cast<int>(rng.index(3)),
                 sign * kGenericLimit * rng.uniform(2.3, 3.0));
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
  return make_pose_set(joint_names, std::move(values), options.count);
}

double training_range_excess(const std::vector<std::string>& joint_names,
                             const torch::Tensor& pose) {
  FSKIN_CHECK(pose.dim() == 2 && pose.size(0) == static_cast<int64_t>(joint_names.size()) &&
                  pose.size(1) == 3,
              "training_range_excess: pose must be [{}, 3]", joint_names.size());
  const auto p = pose.to(torch::kFloat64).contiguous();
  const double* v = p.data_ptr<double>();
  double excess = 0.0;
  for (size_t j = 0; j < joint_names.size(); ++j) {
    const auto range = training_range(joint_names[j]);
    for (int a = 0; a < 3; ++a) {
      const double x = v[3 * j + a];
      excess = std::max({excess, range.low[a] - x, x - range.high[a]});
    }
  }
  return excess;
}

}  // namespace fskin
