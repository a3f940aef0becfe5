// The game-style humanoid of lowpoly_character.h: 55 Mixamo-style joints, a
// T-pose facing +Z, about 500 faceted vertices in 24 closed parts.
#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "data/lowpoly/lowpoly_designs.h"
#include "data/lowpoly/clip_builder.h"
#include "data/lowpoly/loft_mesh.h"
#include "body/procedural/sdf_body.h"

namespace fskin::lowpoly {
namespace {

using procedural::ClipFrame;
using procedural::LoftMesh;
using procedural::Mat3;
using procedural::PaintedWeights;
using procedural::RingSpec;
using procedural::Vec3;

enum Joint : int {
  kRoot,
  kHips,
  kSpine,
  kChest,
  kNeck,
  kHead,
  kHeadTopEnd,
  kLeftEar,
  kRightEar,
  kCape1,
  kCape2,
  kCape3,
  kCapeEnd,
  kLeftArm0,  // first joint of the left arm block
  kArmBlock = 16,
  kRightArm0 = kLeftArm0 + kArmBlock,
  kLeftLeg0 = kRightArm0 + kArmBlock,
  kLegBlock = 5,
  kRightLeg0 = kLeftLeg0 + kLegBlock,
  kNumJoints = kRightLeg0 + kLegBlock
};

// Offsets into an arm block and a leg block.
enum ArmJoint : int { kShoulder, kArm, kForeArm, kHand, kThumb1, kThumb2, kThumbEnd, kIndex1 };
constexpr int kFingerStride = 3;  // per finger: first, second, end (a leaf)
constexpr int kNumFingers = 4;    // thumb, index, middle, ring
enum LegJoint : int { kUpLeg, kLeg, kFoot, kToeBase, kToeEnd };

std::vector<std::string> joint_names() {
  std::vector<std::string> names = {"Root",  "Hips",  "Spine",   "Chest", "Neck",  "Head", "HeadTop_End",
                                    "LeftEar", "RightEar", "Cape1", "Cape2", "Cape3", "Cape_End"};
  const std::vector<std::string> arm = {"Shoulder", "Arm", "ForeArm", "Hand"};
  const std::vector<std::string> fingers = {"Thumb", "Index", "Middle", "Ring"};
  for (const std::string side : {"Left", "Right"}) {
    for (const auto& a : arm) names.push_back(side + a);
    for (const auto& f : fingers)
      for (const std::string k : {"1", "2", "_End"}) names.push_back(side + "Hand" + f + k);
  }
  for (const std::string side : {"Left", "Right"})
    for (const std::string l : {"UpLeg", "Leg", "Foot", "ToeBase", "Toe_End"}) names.push_back(side + l);
  return names;
}

std::vector<int64_t> joint_parents() {
  std::vector<int64_t> p(kNumJoints, -1);
  p[kHips] = kRoot;
  p[kSpine] = kHips;
  p[kChest] = kSpine;
  p[kNeck] = kChest;
  p[kHead] = kNeck;
  p[kHeadTopEnd] = kHead;
  p[kLeftEar] = p[kRightEar] = kHead;
  p[kCape1] = kChest;
  p[kCape2] = kCape1;
  p[kCape3] = kCape2;
  p[kCapeEnd] = kCape3;
  for (int arm : {kLeftArm0, kRightArm0}) {
    p[arm + kShoulder] = kChest;
    p[arm + kArm] = arm + kShoulder;
    p[arm + kForeArm] = arm + kArm;
    p[arm + kHand] = arm + kForeArm;
    for (int f = 0; f < kNumFingers; ++f) {
      const int first = arm + kThumb1 + kFingerStride * f;
      p[first] = arm + kHand;
      p[first + 1] = first;
      p[first + 2] = first + 1;
    }
  }
  for (int leg : {kLeftLeg0, kRightLeg0}) {
    p[leg + kUpLeg] = kHips;
    for (int k = 1; k < kLegBlock; ++k) p[leg + k] = leg + k - 1;
  }
  return p;
}

PaintedWeights only(int bone) { return {{bone, 1.0}}; }
PaintedWeights half(int a, int b) { return {{a, 0.5}, {b, 0.5}}; }

struct Design {
  std::vector<Vec3> joints = std::vector<Vec3>(kNumJoints);
  LoftMesh mesh{kNumJoints};
};

Design design(uint64_t seed, double variation) {
  procedural::SeededUniform uniform(seed);
  const auto vary = [&] { return 1.0 + variation * uniform.symmetric(); };
  const double legs = vary(), arms = vary(), g = vary(), head = vary();
  // Heights on the legs stretch with their length above the ankles; the
  // upper body moves up by as much as the hips did.
  const auto leg_y = [&](double y) { return 0.09 + (y - 0.09) * legs; };
  const double dy = leg_y(0.98) - 0.98;
  const auto up = [&](double x, double y, double z) { return Vec3(x, y + dy, z); };
  const auto arm_x = [&](double x) { return x <= 0.19 ? x : 0.19 + (x - 0.19) * arms; };

  Design d;
  auto& J = d.joints;
  auto& mesh = d.mesh;
  const Vec3 X = Vec3::UnitX(), Y = Vec3::UnitY(), Z = Vec3::UnitZ();
  const auto octagon = procedural::regular_section(8, M_PI / 8), hexagon = procedural::regular_section(6),
             square = procedural::regular_section(4, M_PI / 4), flat = procedural::flat_section();
  // flat: a rectangle with corners at (+-1, +-1); the others have corners on the unit circle.
  const RingSpec kTip{};
  const auto tip = [&](Vec3 at, PaintedWeights w) {
    RingSpec r = kTip;
    r.centre = at;
    r.weights = std::move(w);
    return r;
  };

  J[kRoot] = Vec3::Zero();
  J[kHips] = up(0, 0.98, 0);
  J[kSpine] = up(0, 1.10, 0);
  J[kChest] = up(0, 1.26, 0);
  J[kNeck] = up(0, 1.50, 0);
  J[kHead] = up(0, 1.58, 0.01);
  J[kHeadTopEnd] = up(0, 1.80, 0.01);
  J[kCape1] = up(0, 1.46, -0.10);
  J[kCape2] = up(0, 1.20, -0.155);
  J[kCape3] = up(0, 0.94, -0.185);
  J[kCapeEnd] = up(0, 0.64, -0.215);

  // Torso, neck, head and a pointed nose.
  mesh.loft(octagon, procedural::rings_along({{up(0, 0.86, 0), 0.15 * g, 0.10 * g, only(kHips)},
                                              {up(0, 0.98, 0), 0.16 * g, 0.105 * g, only(kHips)},
                                              {up(0, 1.10, 0), 0.145 * g, 0.095 * g, half(kHips, kSpine)},
                                              {up(0, 1.22, 0), 0.16 * g, 0.10 * g, only(kSpine)},
                                              {up(0, 1.34, 0), 0.185 * g, 0.115 * g, only(kChest)},
                                              {up(0, 1.44, 0), 0.19 * g, 0.11 * g, only(kChest)},
                                              {up(0, 1.50, 0), 0.10 * g, 0.07 * g, only(kChest)}},
                                             X));
  mesh.loft(hexagon, procedural::rings_along({{up(0, 1.44, 0), 0.05, 0.05, only(kChest)},
                                              {up(0, 1.52, 0), 0.048, 0.048, only(kNeck)},
                                              {up(0, 1.61, 0.005), 0.045, 0.045, only(kNeck)}},
                                             X));
  mesh.loft(octagon, procedural::rings_along({{up(0, 1.55, 0.01), 0.06 * head, 0.07 * head, only(kHead)},
                                              {up(0, 1.60, 0.01), 0.085 * head, 0.10 * head, only(kHead)},
                                              {up(0, 1.70, 0.01), 0.095 * head, 0.105 * head, only(kHead)},
                                              {up(0, 1.77, 0.01), 0.07 * head, 0.08 * head, only(kHead)},
                                              tip(up(0, 1.80, 0.01), only(kHead))},
                                             X));
  mesh.loft(square, procedural::rings_along(
                        {{up(0, 1.665, 0.06), 0.018, 0.018, only(kHead)}, tip(up(0, 1.645, 0.135), only(kHead))}, X));
  // The cape: a flat sheet 2 cm thick hanging from the chest, behind the back.
  mesh.loft(flat, procedural::rings_along({{J[kCape1], 0.16, 0.01, only(kCape1)},
                                           {J[kCape2], 0.20, 0.01, only(kCape2)},
                                           {J[kCape3], 0.23, 0.01, only(kCape3)},
                                           {J[kCapeEnd], 0.25, 0.01, only(kCape3)}},
                                          X));

  for (int side : {+1, -1}) {
    const double s = side;
    const int arm = side > 0 ? kLeftArm0 : kRightArm0, leg = side > 0 ? kLeftLeg0 : kRightLeg0,
              ear = side > 0 ? kLeftEar : kRightEar;
    // A pointed ear 1.2 cm thick, facing forward.
    J[ear] = up(s * 0.085, 1.67, 0);
    mesh.loft(flat, procedural::rings_along({{up(s * 0.06, 1.665, 0), 0.028, 0.006, only(ear)},
                                             {up(s * 0.12, 1.71, -0.02), 0.024, 0.005, only(ear)},
                                             tip(up(s * 0.175, 1.755, -0.045), only(ear))},
                                            Y));
    // Arm along +-x; the left side's loft runs outward.
    J[arm + kShoulder] = up(s * 0.05, 1.44, 0);
    J[arm + kArm] = up(s * 0.19, 1.45, 0);
    J[arm + kForeArm] = up(s * arm_x(0.47), 1.45, -0.01);
    J[arm + kHand] = up(s * arm_x(0.73), 1.45, 0);
    mesh.loft(hexagon,
              procedural::rings_along(
                  {{up(s * 0.10, 1.445, 0), 0.055 * g, 0.055 * g, only(arm + kShoulder)},
                   {up(s * 0.19, 1.45, 0), 0.052 * g, 0.05 * g, half(arm + kShoulder, arm + kArm)},
                   {up(s * arm_x(0.33), 1.45, 0), 0.048 * g, 0.045 * g, only(arm + kArm)},
                   {up(s * arm_x(0.47), 1.45, -0.01), 0.042 * g, 0.04 * g, half(arm + kArm, arm + kForeArm)},
                   {up(s * arm_x(0.60), 1.45, -0.005), 0.038 * g, 0.035 * g, only(arm + kForeArm)},
                   {up(s * arm_x(0.735), 1.45, 0), 0.03 * g, 0.028 * g, only(arm + kForeArm)}},
                  Y));
    // Palm: a flat box 3 cm thick.
    mesh.loft(flat, procedural::rings_along({{up(s * arm_x(0.715), 1.45, 0), 0.042, 0.016, only(arm + kHand)},
                                             {up(s * arm_x(0.835), 1.45, 0), 0.046, 0.014, only(arm + kHand)}},
                                            Z));
    // Separate fingers, 1.8 cm wide with 0.8 cm gaps, two bones each and a
    // leaf at the tip; the thumb points forward out of the palm.
    struct FingerPath {
      Vec3 base, joint2, near_tip, tip;
    };
    const std::vector<FingerPath> paths = {
        {up(arm_x(0.74), 1.44, 0.03), up(arm_x(0.78), 1.435, 0.06), up(arm_x(0.80), 1.433, 0.075),
         up(arm_x(0.812), 1.432, 0.084)},
        {up(arm_x(0.82), 1.45, 0.027), up(arm_x(0.87), 1.45, 0.028), up(arm_x(0.905), 1.45, 0.03),
         up(arm_x(0.918), 1.45, 0.03)},
        {up(arm_x(0.82), 1.45, 0), up(arm_x(0.88), 1.45, 0), up(arm_x(0.918), 1.45, 0),
         up(arm_x(0.932), 1.45, 0)},
        {up(arm_x(0.82), 1.45, -0.027), up(arm_x(0.865), 1.45, -0.028), up(arm_x(0.895), 1.45, -0.03),
         up(arm_x(0.907), 1.45, -0.03)}};
    const auto mirror = [&](Vec3 p) { return Vec3(s * p.x(), p.y(), p.z()); };
    for (int f = 0; f < kNumFingers; ++f) {
      const int first = arm + kThumb1 + kFingerStride * f;
      const auto& path = paths[f];
      J[first] = mirror(path.base + 0.25 * (path.joint2 - path.base));
      J[first + 1] = mirror(path.joint2);
      J[first + 2] = mirror(path.tip);
      mesh.loft(flat, procedural::rings_along({{mirror(path.base), 0.0095, 0.0095, only(first)},
                                                 {mirror(path.joint2), 0.009, 0.0085, only(first + 1)},
                                                 {mirror(path.near_tip), 0.0075, 0.007, only(first + 1)},
                                                 tip(mirror(path.tip), only(first + 1))},
                                                Y));
    }
    // Leg along -y and a box foot with a toe.
    J[leg + kUpLeg] = Vec3(s * 0.095, leg_y(0.94), 0);
    J[leg + kLeg] = Vec3(s * 0.10, leg_y(0.52), 0.01);
    J[leg + kFoot] = Vec3(s * 0.10, 0.09, -0.01);
    J[leg + kToeBase] = Vec3(s * 0.10, 0.03, 0.12);
    J[leg + kToeEnd] = Vec3(s * 0.10, 0.03, 0.20);
    mesh.loft(hexagon, procedural::rings_along(
                           {{Vec3(s * 0.09, leg_y(0.99), 0), 0.085 * g, 0.085 * g, only(kHips)},
                            {Vec3(s * 0.095, leg_y(0.90), 0), 0.08 * g, 0.08 * g, only(leg + kUpLeg)},
                            {Vec3(s * 0.097, leg_y(0.72), 0.005), 0.07 * g, 0.07 * g, only(leg + kUpLeg)},
                            {Vec3(s * 0.10, leg_y(0.52), 0.01), 0.056 * g, 0.056 * g, half(leg + kUpLeg, leg + kLeg)},
                            {Vec3(s * 0.10, leg_y(0.30), 0), 0.05 * g, 0.05 * g, only(leg + kLeg)},
                            {Vec3(s * 0.10, leg_y(0.12), -0.01), 0.04 * g, 0.04 * g, only(leg + kLeg)},
                            {Vec3(s * 0.10, 0.07, -0.01), 0.038 * g, 0.038 * g, only(leg + kFoot)}},
                           X));
    mesh.loft(flat, procedural::rings_along(
                        {{Vec3(s * 0.10, 0.04, -0.06), 0.045, 0.04, only(leg + kFoot)},
                         {Vec3(s * 0.10, 0.04, 0.08), 0.048, 0.04, only(leg + kFoot)},
                         {Vec3(s * 0.10, 0.025, 0.125), 0.045, 0.025, half(leg + kFoot, leg + kToeBase)},
                         {Vec3(s * 0.10, 0.017, 0.20), 0.035, 0.017, only(leg + kToeBase)}},
                        X));
  }
  return d;
}

// Animation: local rotations in the rest pose's axes (T-pose, facing +Z,
// left along +X); the right side mirrors the left across x = 0.
std::vector<procedural::ClipSpec> clips() {
  using procedural::mirrored;
  using procedural::rotation_x;
  using procedural::rotation_y;
  using procedural::rotation_z;
  // Both sides: `left` for the left joint, its mirror image for the right one.
  const auto both = [](ClipFrame& f, int left_joint, int right_joint, const Mat3& left) {
    f.rotations[left_joint] = left;
    f.rotations[right_joint] = mirrored(left, 0);
  };
  const auto arms_down = [](ClipFrame& f, int arm, double side, double lower, double swing, double elbow) {
    // Lower the arm (about z), then swing it forward / back (about x); bend the elbow forward.
    f.rotations[arm + kArm] = rotation_x(swing) * rotation_z(-side * lower);
    f.rotations[arm + kForeArm] = rotation_y(-side * elbow);
  };
  const auto curl = [](ClipFrame& f, int arm, double side, double amount) {
    for (int k = 0; k < kNumFingers; ++k) {
      const int first = arm + kThumb1 + kFingerStride * k;
      // Fingers curl towards the palm (-y in the T-pose); the thumb across it.
      const Mat3 r = k == 0 ? rotation_y(side * 0.6 * amount) : rotation_z(-side * amount);
      f.rotations[first] = r;
      f.rotations[first + 1] = r;
    }
  };
  const auto leg = [](ClipFrame& f, int leg0, double hip, double knee, double ankle) {
    f.rotations[leg0 + kUpLeg] = rotation_x(hip);  // negative: forward
    f.rotations[leg0 + kLeg] = rotation_x(knee);   // positive: the shin bends back
    f.rotations[leg0 + kFoot] = rotation_x(ankle);
  };
  const auto cape = [](ClipFrame& f, double a1, double a2, double a3) {
    f.rotations[kCape1] = rotation_x(a1);  // positive: flares out backwards
    f.rotations[kCape2] = rotation_x(a2);
    f.rotations[kCape3] = rotation_x(a3);
  };
  const double tau = 2 * M_PI;
  std::vector<procedural::ClipSpec> specs;
  specs.push_back({"idle", 60, [=](double t, ClipFrame& f) {
                     const double breathe = std::sin(tau * t);
                     f.rotations[kSpine] = rotation_x(0.03 * breathe);
                     f.rotations[kChest] = rotation_x(0.02 * breathe);
                     f.rotations[kNeck] = rotation_y(0.3 * std::sin(tau * t));
                     f.rotations[kHead] = rotation_x(0.08 * std::sin(2 * tau * t));
                     both(f, kLeftEar, kRightEar, rotation_y(-0.15 * std::sin(3 * tau * t)));
                     arms_down(f, kLeftArm0, +1, 1.2 + 0.05 * breathe, 0, 0.25);
                     arms_down(f, kRightArm0, -1, 1.2 + 0.05 * breathe, 0, 0.25);
                     curl(f, kLeftArm0, +1, 0.25 + 0.15 * breathe);
                     curl(f, kRightArm0, -1, 0.25 - 0.15 * breathe);
                     cape(f, 0.05 + 0.05 * breathe, 0.05 * std::sin(tau * t + 1), 0.05 * std::sin(tau * t + 2));
                   }});
  specs.push_back({"walk", 40, [=](double t, ClipFrame& f) {
                     const double a = tau * t, s = std::sin(a);
                     const auto knee = [](double phase) { return 0.1 + 0.55 * std::max(0.0, std::sin(phase - M_PI / 2)); };
                     leg(f, kLeftLeg0, -0.45 * s, knee(a), 0.15 * std::sin(a + 1));
                     leg(f, kRightLeg0, 0.45 * s, knee(a + M_PI), -0.15 * std::sin(a + 1));
                     arms_down(f, kLeftArm0, +1, 1.25, 0.35 * s, 0.3);
                     arms_down(f, kRightArm0, -1, 1.25, -0.35 * s, 0.3);
                     curl(f, kLeftArm0, +1, 0.3);
                     curl(f, kRightArm0, -1, 0.3);
                     f.rotations[kHips] = rotation_y(-0.08 * s);
                     f.rotations[kSpine] = rotation_y(0.08 * s);
                     f.rotations[kHead] = rotation_y(0.05 * s);
                     cape(f, 0.2 + 0.05 * std::sin(2 * a), 0.1, 0.05 * std::sin(2 * a + 1));
                     f.root_translation = {0, 0.02 * std::cos(2 * a), 0};
                   }});
  specs.push_back({"wave", 60, [=](double t, ClipFrame& f) {
                     const double a = tau * t;
                     arms_down(f, kLeftArm0, +1, 1.2, 0, 0.2);
                     curl(f, kLeftArm0, +1, 0.3);
                     // The right arm raised, the forearm up and waving, the fingers spread.
                     f.rotations[kRightArm0 + kArm] = rotation_z(-0.5);
                     f.rotations[kRightArm0 + kForeArm] = rotation_z(-1.0 - 0.35 * std::sin(2 * a));
                     f.rotations[kRightArm0 + kThumb1 + kFingerStride] = rotation_y(0.15);
                     f.rotations[kRightArm0 + kThumb1 + 3 * kFingerStride] = rotation_y(-0.15);
                     f.rotations[kNeck] = rotation_y(-0.2);
                     f.rotations[kHead] = rotation_z(0.1 * std::sin(a));
                     f.rotations[kSpine] = rotation_z(0.05);
                     cape(f, 0.05 + 0.03 * std::sin(a), 0.03 * std::sin(a + 1), 0.03 * std::sin(a + 2));
                   }});
  // Out of distribution: larger hip, knee, elbow and finger angles, a forward
  // lean, the cape flying back.
  specs.push_back({"run", 30, [=](double t, ClipFrame& f) {
                     const double a = tau * t, s = std::sin(a);
                     const auto knee = [](double phase) { return 0.2 + 1.3 * std::max(0.0, std::sin(phase - M_PI / 2)); };
                     leg(f, kLeftLeg0, -0.9 * s, knee(a), 0.3 * std::sin(a + 1));
                     leg(f, kRightLeg0, 0.9 * s, knee(a + M_PI), -0.3 * std::sin(a + 1));
                     arms_down(f, kLeftArm0, +1, 1.3, 0.7 * s, 1.4);
                     arms_down(f, kRightArm0, -1, 1.3, -0.7 * s, 1.4);
                     curl(f, kLeftArm0, +1, 1.2);
                     curl(f, kRightArm0, -1, 1.2);
                     f.rotations[kSpine] = rotation_x(0.2);
                     f.rotations[kChest] = rotation_x(0.1) * rotation_y(0.15 * s);
                     f.rotations[kHead] = rotation_x(-0.15);
                     both(f, kLeftEar, kRightEar, rotation_y(0.3));
                     cape(f, 0.9, 0.25 + 0.1 * std::sin(2 * a), 0.15 * std::sin(2 * a + 1));
                     f.root_translation = {0, 0.05 * std::abs(s), 0};
                   }});
  return specs;
}

}  // namespace

LowPolyCharacter make_humanoid(uint64_t seed, double variation) {
  Design d = design(seed, variation);
  LowPolyCharacter c;
  const auto mesh = d.mesh.mesh();
  // Normalise to 1.8 tall, feet on y = 0.
  const double top = mesh.vertices.select(1, 1).max().item<double>();
  const double scale = 1.8 / top;
  c.model.v_template = mesh.vertices * scale;
  c.model.faces = mesh.faces;
  c.model.weights = d.mesh.weights();
  auto rest = torch::empty({kNumJoints, 3}, torch::kFloat32);
  for (int j = 0; j < kNumJoints; ++j)
    for (int a = 0; a < 3; ++a) rest[j][a] = static_cast<float>(d.joints[j][a] * scale);
  c.model.rest_joints = rest;
  c.model.parents = joint_parents();
  c.model.joint_names = joint_names();
  c.clips = procedural::make_clips(c.model.joint_names, clips());
  c.clips.trans *= scale;
  return c;
}

}  // namespace fskin::lowpoly
