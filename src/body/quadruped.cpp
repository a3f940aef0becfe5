#include "fskin/body/quadruped.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "body/procedural/sdf_body.h"
#include "fskin/core/error.h"

namespace fskin {
namespace {

using procedural::Part;
using procedural::Vec3;

enum Joint : int {
  kHips,
  kSpineLumbar,
  kSpineThoracic,
  kChest,
  kNeckBase,
  kNeckUpper,
  kHead,
  kEarLeftBase,
  kEarLeftTip,
  kEarRightBase,
  kEarRightTip,
  kScapulaLeft,
  kUpperArmLeft,
  kForearmLeft,
  kFrontPawLeft,
  kScapulaRight,
  kUpperArmRight,
  kForearmRight,
  kFrontPawRight,
  kThighLeft,
  kShinLeft,
  kHockLeft,
  kBackPawLeft,
  kThighRight,
  kShinRight,
  kHockRight,
  kBackPawRight,
  kTail0,
  kNumTailJoints = 6,
  kNumJoints = kTail0 + kNumTailJoints
};

// Left-side joints; the right twin of a left joint in a four-joint leg or a
// two-joint ear is the same offset into the right block.
constexpr int kEarBlock = kEarRightBase - kEarLeftBase;
constexpr int kFrontLegBlock = kScapulaRight - kScapulaLeft;
constexpr int kBackLegBlock = kThighRight - kThighLeft;

// A joint's bone: the capsule from the joint to its child `child`, or (leaves,
// child < 0) to the joint plus `tip`, with radii r0 at the joint and r1 at the end.
struct BoneSpec {
  int child = -1;
  Vec3 tip = Vec3::Zero();
  double r0 = 0, r1 = 0;
};

struct Design {
  std::vector<Vec3> joints = std::vector<Vec3>(kNumJoints);
  std::vector<BoneSpec> bones = std::vector<BoneSpec>(kNumJoints);
  std::vector<Part> parts;
};

// Proportions in metres for an animal about 1.6 m from nose to tail tip
// before the final scaling to options.length; `side` is +1 for left (+x).
Design design_quadruped(const QuadrupedOptions& o) {
  procedural::SeededUniform uniform(o.seed);
  const auto vary = [&] { return 1.0 + o.variation * uniform.symmetric(); };
  const double legs = vary(), body = vary(), girth = vary(), neck = vary(), tail = vary(), head = vary();
  Design d;
  auto& J = d.joints;
  const double leg_top = 0.56 * legs;  // height of the hip and shoulder joints above the soles
  J[kHips] = {0, leg_top, -0.28 * body};
  J[kSpineLumbar] = {0, leg_top + 0.02, -0.12 * body};
  J[kSpineThoracic] = {0, leg_top + 0.03, 0.04 * body};
  J[kChest] = {0, leg_top + 0.02, 0.20 * body};
  J[kNeckBase] = J[kChest] + Vec3(0, 0.04, 0.12) * neck;
  J[kNeckUpper] = J[kNeckBase] + Vec3(0, 0.10, 0.08) * neck;
  J[kHead] = J[kNeckUpper] + Vec3(0, 0.07, 0.06) * neck;
  for (int side : {+1, -1}) {
    const int ear = side > 0 ? 0 : kEarBlock, front = side > 0 ? 0 : kFrontLegBlock,
              back = side > 0 ? 0 : kBackLegBlock;
    J[kEarLeftBase + ear] = J[kHead] + Vec3(side * 0.05, 0.08, -0.01) * head;
    J[kEarLeftTip + ear] = J[kEarLeftBase + ear] + Vec3(side * 0.025, 0.08, -0.01) * head;
    J[kScapulaLeft + front] = {side * 0.09 * girth, leg_top + 0.02, J[kChest].z() + 0.04};
    J[kUpperArmLeft + front] = {side * 0.11 * girth, 0.75 * leg_top, J[kChest].z() + 0.07};
    J[kForearmLeft + front] = {side * 0.11 * girth, 0.46 * leg_top, J[kChest].z() + 0.04};
    J[kFrontPawLeft + front] = {side * 0.11 * girth, 0.07, J[kChest].z() + 0.05};
    J[kThighLeft + back] = {side * 0.10 * girth, 0.93 * leg_top, J[kHips].z() - 0.02};
    J[kShinLeft + back] = {side * 0.11 * girth, 0.57 * leg_top, J[kHips].z() + 0.06};
    J[kHockLeft + back] = {side * 0.11 * girth, 0.28 * leg_top, J[kHips].z() - 0.07};
    J[kBackPawLeft + back] = {side * 0.11 * girth, 0.06, J[kHips].z() - 0.05};
  }
  const Vec3 tail_step = Vec3(0, -0.015, -0.085) * tail;
  for (int k = 0; k < kNumTailJoints; ++k) J[kTail0 + k] = Vec3(0, leg_top + 0.02, J[kHips].z() - 0.14) + k * tail_step;

  const double g = girth;
  auto& P = d.parts;
  const auto ellipsoid = Part::make_ellipsoid;
  const auto capsule = Part::make_capsule;
  const double mid_z = 0.5 * (J[kHips].z() + J[kChest].z());
  P.push_back(ellipsoid({0, leg_top, mid_z}, Vec3(0.14 * g, 0.15 * g, 0.34 * body), 0));
  P.push_back(ellipsoid(J[kChest] + Vec3(0, -0.05, -0.02), Vec3(0.135, 0.17, 0.15) * g, 0.06));
  P.push_back(ellipsoid(J[kHips] + Vec3(0, -0.02, 0.01), Vec3(0.14, 0.14, 0.13) * g, 0.06));
  P.push_back(capsule(J[kNeckBase] + Vec3(0, -0.02, -0.04), J[kHead] + Vec3(0, -0.02, -0.02), 0.085 * g, 0.065 * g,
                      0.05));
  P.push_back(ellipsoid(J[kHead] + Vec3(0, 0.01, 0.01), Vec3(0.08, 0.085, 0.10) * head, 0.04));
  const Vec3 snout_tip = J[kHead] + Vec3(0, -0.045, 0.20) * head;
  P.push_back(capsule(J[kHead] + Vec3(0, -0.01, 0.06) * head, snout_tip, 0.05 * head, 0.033 * head, 0.03));
  for (int side : {+1, -1}) {
    const int ear = side > 0 ? 0 : kEarBlock, front = side > 0 ? 0 : kFrontLegBlock,
              back = side > 0 ? 0 : kBackLegBlock;
    const Vec3 ear_end = J[kEarLeftTip + ear] + Vec3(side * 0.015, 0.07, -0.01) * head;
    P.push_back(capsule(J[kEarLeftBase + ear] + Vec3(0, -0.02, 0), ear_end, 0.032 * head, 0.014 * head, 0.02));
    P.push_back(capsule(J[kScapulaLeft + front], J[kUpperArmLeft + front], 0.07 * g, 0.055 * g, 0.04));
    P.push_back(capsule(J[kUpperArmLeft + front], J[kForearmLeft + front], 0.05 * g, 0.038 * g, 0.02));
    P.push_back(capsule(J[kForearmLeft + front], J[kFrontPawLeft + front], 0.035 * g, 0.028 * g, 0.015));
    P.push_back(ellipsoid(J[kFrontPawLeft + front] + Vec3(0, -0.03, 0.03), Vec3(0.035, 0.03, 0.055) * g, 0.015));
    P.push_back(capsule(J[kThighLeft + back], J[kShinLeft + back], 0.08 * g, 0.05 * g, 0.04));
    P.push_back(capsule(J[kShinLeft + back], J[kHockLeft + back], 0.042 * g, 0.03 * g, 0.02));
    P.push_back(capsule(J[kHockLeft + back], J[kBackPawLeft + back], 0.03 * g, 0.027 * g, 0.015));
    P.push_back(ellipsoid(J[kBackPawLeft + back] + Vec3(0, -0.02, 0.03), Vec3(0.035, 0.03, 0.055) * g, 0.015));
  }
  const Vec3 tail_end = J[kTail0 + kNumTailJoints - 1] + tail_step;
  const auto tail_radius = [&](int k) { return (0.045 - 0.005 * k) * g; };
  P.push_back(capsule(J[kHips] + Vec3(0, 0.01, -0.08), J[kTail0], 0.06 * g, tail_radius(0), 0.03));
  for (int k = 0; k < kNumTailJoints; ++k)
    P.push_back(capsule(J[kTail0 + k], k + 1 < kNumTailJoints ? J[kTail0 + k + 1] : tail_end, tail_radius(k),
                        tail_radius(k + 1), 0.01));

  // Bones: the region each joint's frame moves.
  const auto bone = [&](int joint, int child, double r0, double r1, Vec3 tip = Vec3::Zero()) {
    d.bones[joint] = BoneSpec{child, tip, r0 * g, r1 * g};
  };
  bone(kHips, kSpineLumbar, 0.14, 0.14);
  bone(kSpineLumbar, kSpineThoracic, 0.14, 0.14);
  bone(kSpineThoracic, kChest, 0.14, 0.14);
  bone(kChest, kNeckBase, 0.14, 0.10);
  bone(kNeckBase, kNeckUpper, 0.075, 0.07);
  bone(kNeckUpper, kHead, 0.065, 0.065);
  bone(kHead, -1, 0.08, 0.04, snout_tip - J[kHead]);
  for (int side : {+1, -1}) {
    const int ear = side > 0 ? 0 : kEarBlock, front = side > 0 ? 0 : kFrontLegBlock,
              back = side > 0 ? 0 : kBackLegBlock;
    bone(kEarLeftBase + ear, kEarLeftTip + ear, 0.028, 0.02);
    bone(kEarLeftTip + ear, -1, 0.02, 0.014, Vec3(side * 0.015, 0.07, -0.01) * head);
    bone(kScapulaLeft + front, kUpperArmLeft + front, 0.065, 0.055);
    bone(kUpperArmLeft + front, kForearmLeft + front, 0.05, 0.038);
    bone(kForearmLeft + front, kFrontPawLeft + front, 0.035, 0.028);
    bone(kFrontPawLeft + front, -1, 0.03, 0.03, Vec3(0, -0.04, 0.07));
    bone(kThighLeft + back, kShinLeft + back, 0.075, 0.05);
    bone(kShinLeft + back, kHockLeft + back, 0.042, 0.03);
    bone(kHockLeft + back, kBackPawLeft + back, 0.03, 0.027);
    bone(kBackPawLeft + back, -1, 0.03, 0.03, Vec3(0, -0.03, 0.07));
  }
  for (int k = 0; k < kNumTailJoints; ++k)
    bone(kTail0 + k, k + 1 < kNumTailJoints ? kTail0 + k + 1 : -1, tail_radius(k) / g, tail_radius(k + 1) / g,
         k + 1 < kNumTailJoints ? Vec3::Zero() : tail_step);

  // Scale everything so the nose-to-tail-tip length is options.length.
  const double s = o.length / (snout_tip.z() + 0.033 * head - (tail_end.z() - tail_radius(kNumTailJoints)));
  for (auto& j : J) j *= s;
  for (auto& b : d.bones) {
    b.tip *= s;
    b.r0 *= s;
    b.r1 *= s;
  }
  for (auto& part : P) part.scale(s);
  return d;
}

}  // namespace

void QuadrupedOptions::validate() const {
  FSKIN_CHECK(resolution >= 48 && resolution <= 512, "quadruped: --resolution must be in [48, 512], got {}",
              resolution);
  FSKIN_CHECK(length >= 0.01 && length <= 100.0, "quadruped: --length must be in [0.01, 100] m, got {}", length);
  FSKIN_CHECK(variation >= 0.0 && variation <= 0.1, "quadruped: --variation must be in [0, 0.1], got {}",
              variation);
}

const std::vector<std::string>& quadruped_joint_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = {"hips",        "spine_lumbar", "spine_thoracic", "chest",      "neck_base",
                                  "neck_upper",  "head",         "ear_l_base",     "ear_l_tip",  "ear_r_base",
                                  "ear_r_tip",   "scapula_l",    "upper_arm_l",    "forearm_l",  "front_paw_l",
                                  "scapula_r",   "upper_arm_r",  "forearm_r",      "front_paw_r", "thigh_l",
                                  "shin_l",      "hock_l",       "back_paw_l",     "thigh_r",    "shin_r",
                                  "hock_r",      "back_paw_r"};
    for (int k = 0; k < kNumTailJoints; ++k) n.push_back("tail_" + std::to_string(k));
    return n;
  }();
  return names;
}

const std::vector<int64_t>& quadruped_parents() {
  static const std::vector<int64_t> parents = [] {
    std::vector<int64_t> p(kNumJoints, -1);
    p[kSpineLumbar] = kHips;
    p[kSpineThoracic] = kSpineLumbar;
    p[kChest] = kSpineThoracic;
    p[kNeckBase] = kChest;
    p[kNeckUpper] = kNeckBase;
    p[kHead] = kNeckUpper;
    for (int ear : {0, kEarBlock}) {
      p[kEarLeftBase + ear] = kHead;
      p[kEarLeftTip + ear] = kEarLeftBase + ear;
    }
    for (int front : {0, kFrontLegBlock}) {
      p[kScapulaLeft + front] = kChest;
      for (int k = 1; k < 4; ++k) p[kScapulaLeft + front + k] = kScapulaLeft + front + k - 1;
    }
    for (int back : {0, kBackLegBlock}) {
      p[kThighLeft + back] = kHips;
      for (int k = 1; k < 4; ++k) p[kThighLeft + back + k] = kThighLeft + back + k - 1;
    }
    p[kTail0] = kHips;
    for (int k = 1; k < kNumTailJoints; ++k) p[kTail0 + k] = kTail0 + k - 1;
    return p;
  }();
  return parents;
}

bool is_builtin_quadruped(const std::vector<std::string>& joint_names) {
  return joint_names == quadruped_joint_names();
}

BodyModelData make_quadruped(const QuadrupedOptions& options) {
  options.validate();
  const Design design = design_quadruped(options);
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const auto& part : design.parts) part.extend(lo, hi);
  const double cell = options.length / options.resolution;
  // Smooth unions only grow the shape by a fraction of the blend radius.
  lo -= Vec3::Constant(3 * cell + 0.03 * options.length);
  hi += Vec3::Constant(3 * cell + 0.03 * options.length);
  const Mesh mesh = procedural::mesh_distance_field(
      [&](const Vec3& p) { return procedural::union_distance(design.parts, p); }, lo, hi, cell,
      fmt::format("built-in quadruped at resolution {}", options.resolution));
  const auto vertices = procedural::to_points(mesh.vertices);
  const auto V = static_cast<int64_t>(vertices.size());

  BodyModelData data;
  data.v_template = mesh.vertices;
  data.faces = mesh.faces;
  data.parents = quadruped_parents();
  data.joint_names = quadruped_joint_names();

  auto regressed = procedural::regress_joints(design.joints, vertices);
  data.J_regressor = regressed.J_regressor;
  const auto& rest = regressed.rest;

  // Bones follow the regressed joints.
  std::vector<procedural::BoneCapsule> capsules;
  for (int j = 0; j < kNumJoints; ++j) {
    const auto& b = design.bones[j];
    capsules.push_back({rest[j], b.child >= 0 ? rest[b.child] : Vec3(rest[j] + b.tip), b.r0, b.r1});
  }
  const double scale = options.length / 1.6;
  auto weights = procedural::capsule_skinning_weights(capsules, vertices, 0.02 * scale);
  procedural::smooth_over_mesh(weights, kNumJoints, procedural::mesh_adjacency(mesh),
                               std::max(1, options.resolution / 20));
  data.weights = torch::from_blob(weights.data(), {V, kNumJoints}, torch::kFloat64).to(torch::kFloat32);
  return data;
}

BodyModel make_quadruped_model(const QuadrupedOptions& options) {
  return BodyModel(make_quadruped(options), "built-in quadruped");
}

}  // namespace fskin
