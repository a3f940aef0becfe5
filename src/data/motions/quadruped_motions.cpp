// Motions of the built-in quadruped (quadruped.h): +Y up, facing +Z, legs and
// their segments hanging along -Y in the rest pose. A rotation about +X by a
// positive angle swings a hanging segment's lower end backwards (-Z), pitches
// a forward-pointing bone (spine, head) down and raises the tail, which
// points backwards; a rotation about +Y turns the spine, neck and tail to the
// animal's left (+X) or right; about +Z it swings a left leg outwards.
#include <cmath>
#include <map>

#include "data/motions/motion_library.h"

namespace fskin::motions {
namespace {

const std::map<std::string, JointRange>& quadruped_training_ranges() {
  static const std::map<std::string, JointRange> ranges = [] {
    std::map<std::string, JointRange> r = {
        {"hips", {{-0.2, -0.3, -0.1}, {0.15, 0.3, 0.1}}},
        {"spine_lumbar", {{-0.15, -0.15, -0.1}, {0.15, 0.15, 0.1}}},
        {"spine_thoracic", {{-0.15, -0.15, -0.1}, {0.15, 0.15, 0.1}}},
        {"chest", {{-0.15, -0.15, -0.1}, {0.15, 0.15, 0.1}}},
        {"neck_base", {{-0.35, -0.35, -0.1}, {0.35, 0.35, 0.1}}},
        {"neck_upper", {{-0.3, -0.3, -0.1}, {0.3, 0.3, 0.1}}},
        {"head", {{-0.3, -0.3, -0.15}, {0.3, 0.3, 0.15}}},
    };
    for (const char* side : {"l", "r"}) {
      const std::string s(side);
      r["ear_" + s + "_base"] = {{-0.3, -0.2, -0.3}, {0.3, 0.2, 0.3}};
      r["ear_" + s + "_tip"] = {{-0.3, -0.2, -0.3}, {0.3, 0.2, 0.3}};
      r["scapula_" + s] = {{-0.3, -0.05, -0.08}, {0.3, 0.05, 0.08}};
      r["upper_arm_" + s] = {{-0.6, -0.08, -0.12}, {0.5, 0.08, 0.12}};
      r["forearm_" + s] = {{-0.1, -0.05, -0.05}, {1.0, 0.05, 0.05}};
      r["front_paw_" + s] = {{-0.2, -0.05, -0.05}, {1.0, 0.05, 0.05}};
      r["thigh_" + s] = {{-0.6, -0.08, -0.15}, {0.6, 0.08, 0.15}};
      r["shin_" + s] = {{-0.9, -0.05, -0.05}, {0.1, 0.05, 0.05}};
      r["hock_" + s] = {{-0.1, -0.05, -0.05}, {0.9, 0.05, 0.05}};
      r["back_paw_" + s] = {{-0.5, -0.05, -0.05}, {0.3, 0.05, 0.05}};
    }
    for (int k = 0; k < 6; ++k) r["tail_" + std::to_string(k)] = {{-0.3, -0.35, -0.1}, {0.3, 0.35, 0.1}};
    return r;
  }();
  return ranges;
}

const char* const kSides[] = {"l", "r"};
const char* const kSpine[] = {"spine_lumbar", "spine_thoracic", "chest"};

// One leg through a gait cycle at phase `phase`: the upper segment swings
// forwards and back, the lower joints fold while the leg swings forwards.
void leg_cycle(PoseBuilder& pose, bool front, const std::string& side, double phase, double amp, double fold) {
  const double swing = -0.45 * amp * std::sin(phase), lift = fold * amp * std::max(0.0, std::cos(phase));
  if (front) {
    pose.add("upper_arm_" + side, kX, swing);
    pose.add("forearm_" + side, kX, 0.8 * lift);
    pose.add("front_paw_" + side, kX, 0.7 * lift);
  } else {
    pose.add("thigh_" + side, kX, swing);
    pose.add("shin_" + side, kX, -0.7 * lift);
    pose.add("hock_" + side, kX, 0.6 * lift);
  }
}

void tail_wag(PoseBuilder& pose, double phase, double amp, double yaw, double pitch) {
  for (int k = 0; k < 6; ++k) {
    const std::string tail = "tail_" + std::to_string(k);
    pose.add(tail, kY, yaw * amp * std::sin(phase + 0.5 * k));
    pose.add(tail, kX, pitch * amp * std::cos(phase + 0.4 * k));
  }
}

void natural_motion(int family, double phase, double amp, PoseBuilder& pose) {
  switch (family) {
    case 0:  // walk: lateral sequence, hind left, fore left, hind right, fore right
      leg_cycle(pose, false, "l", phase, amp, 1.0);
      leg_cycle(pose, true, "l", phase - 0.5 * M_PI, amp, 1.0);
      leg_cycle(pose, false, "r", phase - M_PI, amp, 1.0);
      leg_cycle(pose, true, "r", phase - 1.5 * M_PI, amp, 1.0);
      pose.add("neck_base", kX, 0.08 * amp * std::sin(2 * phase));
      for (const char* spine : kSpine) pose.add(spine, kY, 0.06 * amp * std::sin(phase));
      tail_wag(pose, phase, amp, 0.15, 0.05);
      break;
    case 1:  // trot: diagonal pairs in phase, the lower joints folding more
      leg_cycle(pose, true, "l", phase, amp, 1.2);
      leg_cycle(pose, false, "r", phase, amp, 1.2);
      leg_cycle(pose, true, "r", phase + M_PI, amp, 1.2);
      leg_cycle(pose, false, "l", phase + M_PI, amp, 1.2);
      pose.add("neck_base", kX, -0.1 * amp);
      tail_wag(pose, 2 * phase, amp, 0.1, 0.1);
      break;
    case 2: {  // sit down and up: hind legs fold, front up, head raised
      const double bend = 0.5 * amp * (1 - std::cos(phase));
      pose.add("hips", kX, -0.2 * bend);
      pose.add("spine_lumbar", kX, -0.15 * bend);
      for (const char* side : kSides) {
        const std::string s(side);
        pose.add("thigh_" + s, kX, -0.6 * bend);
        pose.add("shin_" + s, kX, -0.9 * bend);
        pose.add("hock_" + s, kX, 0.9 * bend);
        pose.add("upper_arm_" + s, kX, 0.2 * bend);
      }
      pose.add("neck_base", kX, -0.3 * bend);
      pose.add("head", kX, 0.2 * bend);
      tail_wag(pose, phase, amp, 0.1, -0.2 * bend);
      break;
    }
    default:  // look around: neck and head turn and nod, tail up and down, ears turn
      pose.add("neck_base", kY, 0.35 * amp * std::sin(phase));
      pose.add("neck_upper", kY, 0.25 * amp * std::sin(phase));
      pose.add("neck_base", kX, 0.3 * amp * std::cos(phase));
      pose.add("head", kX, 0.25 * amp * std::cos(phase + 0.5));
      tail_wag(pose, phase, amp, 0.3, 0.25);
      for (const char* side : kSides) pose.add(std::string("ear_") + side + "_base", kX, 0.25 * amp * std::sin(phase));
      break;
  }
}

// Extreme poses, each at least 0.35 rad beyond a training range.
std::vector<Template> ood_templates(const PoseBuilder&) {
  std::vector<Template> out;
  const auto sign_of = [](Rng& rng) { return rng.uniform() < 0.5 ? -1.0 : 1.0; };
  out.push_back([](Rng& rng, PoseBuilder& p) {  // tail curled up over the back
    for (int k = 0; k < 6; ++k) p.set("tail_" + std::to_string(k), kX, rng.uniform(0.65, 0.9));
  });
  out.push_back([=](Rng& rng, PoseBuilder& p) {  // head turned back to one side
    const double sign = sign_of(rng);
    p.set("neck_base", kY, sign * rng.uniform(0.8, 1.1));
    p.set("neck_upper", kY, sign * rng.uniform(0.6, 0.9));
    p.set("head", kY, sign * rng.uniform(0.2, 0.4));
  });
  out.push_back([](Rng& rng, PoseBuilder& p) {  // gallop stretch: fore legs forward, hind legs back
    for (const char* side : kSides) {
      p.set(std::string("upper_arm_") + side, kX, -rng.uniform(1.0, 1.3));
      p.set(std::string("thigh_") + side, kX, rng.uniform(1.0, 1.2));
    }
  });
  out.push_back([](Rng& rng, PoseBuilder& p) {  // rearing up, front legs tucked
    p.set("hips", kX, -rng.uniform(0.6, 0.9));
    for (const char* side : kSides) {
      const std::string s(side);
      p.set("thigh_" + s, kX, -rng.uniform(0.5, 0.8));
      p.set("forearm_" + s, kX, rng.uniform(1.4, 1.9));
      p.set("front_paw_" + s, kX, rng.uniform(0.8, 1.2));
    }
  });
  out.push_back([](Rng& rng, PoseBuilder& p) {  // lying down: all legs folded
    for (const char* side : kSides) {
      const std::string s(side);
      p.set("upper_arm_" + s, kX, -rng.uniform(1.1, 1.4));
      p.set("forearm_" + s, kX, rng.uniform(0.1, 0.3));
      p.set("thigh_" + s, kX, -rng.uniform(1.1, 1.3));
      p.set("shin_" + s, kX, -rng.uniform(1.2, 1.5));
      p.set("hock_" + s, kX, rng.uniform(1.3, 1.6));
    }
  });
  out.push_back([=](Rng& rng, PoseBuilder& p) {  // a hind leg lifted sideways
    const bool left = rng.uniform() < 0.5;
    const std::string s = left ? "l" : "r";
    p.set("thigh_" + s, kZ, (left ? 1.0 : -1.0) * rng.uniform(0.8, 1.1));
    p.set("shin_" + s, kX, -rng.uniform(0.3, 0.6));
  });
  out.push_back([=](Rng& rng, PoseBuilder& p) {  // the body bent sideways into a C
    const double sign = sign_of(rng);
    for (const char* spine : kSpine) p.set(spine, kY, sign * rng.uniform(0.5, 0.6));
    p.set("neck_base", kY, sign * rng.uniform(0.4, 0.6));
  });
  out.push_back([](Rng& rng, PoseBuilder& p) {  // head down to the ground
    p.set("neck_base", kX, rng.uniform(0.8, 1.1));
    p.set("neck_upper", kX, rng.uniform(0.4, 0.6));
  });
  return out;
}

}  // namespace

MotionLibrary quadruped_motions(const std::vector<std::string>& names) {
  MotionLibrary library;
  const auto& table = quadruped_training_ranges();
  for (const auto& name : names) {
    library.ranges.push_back(table.at(name));
    library.oscillate.push_back(name.rfind("ear_", 0) == 0);  // the ears twitch in every motion
  }
  library.families = 4;
  library.natural = natural_motion;
  library.ood_templates = ood_templates;
  return library;
}

}  // namespace fskin::motions
