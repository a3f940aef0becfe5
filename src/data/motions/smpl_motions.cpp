#include <cmath>
#include <map>

#include "data/motions/motion_library.h"

namespace fskin::motions {
namespace {

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

}  // namespace

MotionLibrary smpl_motions(const std::vector<std::string>& names) {
  MotionLibrary library;
  const auto& table = smpl_training_ranges();
  for (const auto& name : names) {
    const auto it = table.find(name);
    library.oscillate.push_back(it == table.end());
    JointRange generic;
    generic.low.fill(-kGenericLimit);
    generic.high.fill(kGenericLimit);
    library.ranges.push_back(it == table.end() ? generic : it->second);
  }
  library.families = 4;
  library.natural = natural_motion;
  library.ood_templates = ood_templates;
  return library;
}

}  // namespace fskin::motions
