// The game-style animal of lowpoly_character.h: a fox with 34 Blender-style
// joints, facing +X, about 280 faceted vertices in 16 closed parts, thin flat
// ears and a flat tail.
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
  kPelvis,
  kSpine,
  kChest,
  kNeck,
  kHead,
  kNoseEnd,
  kLeftEar0,  // ear, ear_tip, ear_end (a leaf) per side
  kEarBlock = 3,
  kRightEar0 = kLeftEar0 + kEarBlock,
  kLeftFront0 = kRightEar0 + kEarBlock,  // upper_arm, forearm, front_paw, front_toe_end per side
  kLegBlock = 4,
  kRightFront0 = kLeftFront0 + kLegBlock,
  kLeftBack0 = kRightFront0 + kLegBlock,  // thigh, shin, back_paw, back_toe_end per side
  kRightBack0 = kLeftBack0 + kLegBlock,
  kTail0 = kRightBack0 + kLegBlock,  // tail.001 .. tail.004, tail_end (a leaf)
  kTailJoints = 5,
  kNumJoints = kTail0 + kTailJoints
};

std::vector<std::string> joint_names() {
  std::vector<std::string> names = {"root", "pelvis", "spine", "chest", "neck", "head", "nose_end"};
  for (const std::string side : {".L", ".R"})
    for (const std::string e : {"ear", "ear_tip", "ear_end"}) names.push_back(e + side);
  for (const std::string side : {".L", ".R"})
    for (const std::string l : {"upper_arm", "forearm", "front_paw", "front_toe_end"}) names.push_back(l + side);
  for (const std::string side : {".L", ".R"})
    for (const std::string l : {"thigh", "shin", "back_paw", "back_toe_end"}) names.push_back(l + side);
  for (const std::string t : {"tail.001", "tail.002", "tail.003", "tail.004", "tail_end"}) names.push_back(t);
  return names;
}

std::vector<int64_t> joint_parents() {
  std::vector<int64_t> p(kNumJoints, -1);
  p[kPelvis] = kRoot;
  p[kSpine] = kPelvis;
  p[kChest] = kSpine;
  p[kNeck] = kChest;
  p[kHead] = kNeck;
  p[kNoseEnd] = kHead;
  for (int ear : {kLeftEar0, kRightEar0}) {
    p[ear] = kHead;
    p[ear + 1] = ear;
    p[ear + 2] = ear + 1;
  }
  for (int leg : {kLeftFront0, kRightFront0, kLeftBack0, kRightBack0}) {
    p[leg] = leg == kLeftFront0 || leg == kRightFront0 ? kChest : kPelvis;
    for (int k = 1; k < kLegBlock; ++k) p[leg + k] = leg + k - 1;
  }
  p[kTail0] = kPelvis;
  for (int k = 1; k < kTailJoints; ++k) p[kTail0 + k] = kTail0 + k - 1;
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
  const double legs = vary(), g = vary(), tail = vary(), head = vary();
  // Heights on the legs stretch with their length; the body rides on them.
  const auto leg_y = [&](double y) { return y * legs; };
  const double dy = leg_y(0.40) - 0.40;
  const auto body = [&](double x, double y, double z) { return Vec3(x, y + dy, z); };

  Design d;
  auto& J = d.joints;
  auto& mesh = d.mesh;
  const Vec3 X = Vec3::UnitX(), Z = Vec3::UnitZ();
  // flat: a rectangle with corners at (+-1, +-1); the others have corners on the unit circle.
  const auto octagon = procedural::regular_section(8, M_PI / 8), hexagon = procedural::regular_section(6),
             flat = procedural::flat_section();
  const auto tip = [](Vec3 at, PaintedWeights w) {
    RingSpec r;
    r.centre = at;
    r.weights = std::move(w);
    return r;
  };

  J[kRoot] = Vec3::Zero();
  J[kPelvis] = body(-0.17, 0.40, 0);
  J[kSpine] = body(-0.03, 0.41, 0);
  J[kChest] = body(0.12, 0.41, 0);
  J[kNeck] = body(0.19, 0.45, 0);
  J[kHead] = body(0.26, 0.53, 0);
  J[kNoseEnd] = body(0.26 + 0.17 * head, 0.49, 0);

  // Body (wide along z, tall along y), neck, and a head that narrows to a pointed muzzle.
  mesh.loft(octagon, procedural::rings_along({{body(-0.27, 0.41, 0), 0.05 * g, 0.06 * g, only(kPelvis)},
                                              {body(-0.19, 0.41, 0), 0.07 * g, 0.085 * g, only(kPelvis)},
                                              {body(-0.10, 0.41, 0), 0.065 * g, 0.08 * g, half(kPelvis, kSpine)},
                                              {body(-0.01, 0.41, 0), 0.065 * g, 0.08 * g, only(kSpine)},
                                              {body(0.07, 0.405, 0), 0.075 * g, 0.095 * g, half(kSpine, kChest)},
                                              {body(0.15, 0.41, 0), 0.075 * g, 0.09 * g, only(kChest)},
                                              {body(0.21, 0.43, 0), 0.05 * g, 0.06 * g, only(kChest)}},
                                             Z));
  mesh.loft(hexagon, procedural::rings_along({{body(0.15, 0.43, 0), 0.04 * g, 0.045 * g, only(kChest)},
                                              {body(0.20, 0.47, 0), 0.038 * g, 0.04 * g, only(kNeck)},
                                              {body(0.255, 0.53, 0), 0.036 * g, 0.038 * g, only(kNeck)}},
                                             Z));
  mesh.loft(hexagon, procedural::rings_along({{body(0.215, 0.545, 0), 0.035 * head, 0.035 * head, only(kHead)},
                                              {body(0.255, 0.55, 0), 0.055 * head, 0.05 * head, only(kHead)},
                                              {body(0.26 + 0.04 * head, 0.535, 0), 0.048 * head, 0.042 * head, only(kHead)},
                                              {body(0.26 + 0.10 * head, 0.515, 0), 0.025 * head, 0.022 * head, only(kHead)},
                                              tip(J[kNoseEnd], only(kHead))},
                                             Z));
  for (int side : {+1, -1}) {
    // Left is -z: the fox faces +x with +y up.
    const double s = -side;
    const int ear = side > 0 ? kLeftEar0 : kRightEar0, front = side > 0 ? kLeftFront0 : kRightFront0,
              back = side > 0 ? kLeftBack0 : kRightBack0;
    // A pointed ear 0.8 cm thick facing forward, with two bones and a leaf at the tip.
    J[ear] = body(0.265, 0.585, s * 0.035);
    J[ear + 1] = body(0.275, 0.65, s * 0.05);
    J[ear + 2] = body(0.285, 0.72, s * 0.06);
    mesh.loft(flat, procedural::rings_along({{body(0.262, 0.57, s * 0.032), 0.03, 0.004, only(ear)},
                                             {J[ear + 1], 0.018, 0.0035, only(ear + 1)},
                                             tip(J[ear + 2], only(ear + 1))},
                                            Z));
    // Thin legs and flat paws; the leaf at the toes has no vertices.
    J[front] = Vec3(0.13, leg_y(0.36), s * 0.06);
    J[front + 1] = Vec3(0.15, leg_y(0.21), s * 0.06);
    J[front + 2] = Vec3(0.14, 0.045, s * 0.06);
    J[front + 3] = Vec3(0.19, 0.01, s * 0.06);
    mesh.loft(hexagon, procedural::rings_along(
                           {{body(0.13, 0.40, s * 0.055), 0.035 * g, 0.03 * g, only(kChest)},
                            {Vec3(0.13, leg_y(0.35), s * 0.06), 0.03 * g, 0.028 * g, only(front)},
                            {J[front + 1], 0.02 * g, 0.02 * g, half(front, front + 1)},
                            {Vec3(0.145, 0.06, s * 0.06), 0.016 * g, 0.016 * g, only(front + 1)},
                            {Vec3(0.14, 0.035, s * 0.06), 0.016 * g, 0.016 * g, only(front + 2)}},
                           X));
    mesh.loft(flat, procedural::rings_along({{Vec3(0.12, 0.02, s * 0.06), 0.02, 0.018, only(front + 2)},
                                             {Vec3(0.195, 0.012, s * 0.06), 0.017, 0.01, only(front + 2)}},
                                            Z));
    J[back] = Vec3(-0.18, leg_y(0.37), s * 0.065);
    J[back + 1] = Vec3(-0.13, leg_y(0.22), s * 0.065);
    J[back + 2] = Vec3(-0.19, 0.05, s * 0.065);
    J[back + 3] = Vec3(-0.14, 0.01, s * 0.065);
    mesh.loft(hexagon, procedural::rings_along(
                           {{body(-0.18, 0.41, s * 0.05), 0.05 * g, 0.05 * g, only(kPelvis)},
                            {Vec3(-0.175, leg_y(0.36), s * 0.065), 0.045 * g, 0.04 * g, only(back)},
                            {J[back + 1], 0.022 * g, 0.022 * g, half(back, back + 1)},
                            {Vec3(-0.19, 0.06, s * 0.065), 0.016 * g, 0.016 * g, only(back + 1)},
                            {Vec3(-0.19, 0.04, s * 0.065), 0.016 * g, 0.016 * g, only(back + 2)}},
                           X));
    mesh.loft(flat, procedural::rings_along({{Vec3(-0.21, 0.02, s * 0.065), 0.02, 0.018, only(back + 2)},
                                             {Vec3(-0.135, 0.012, s * 0.065), 0.017, 0.01, only(back + 2)}},
                                            Z));
  }
  // A flat tail 1.2 cm thick and up to 10 cm wide, one bone per ring.
  const std::vector<Vec3> tail_path = {body(-0.23, 0.42, 0), body(-0.25 - 0.08 * tail, 0.44, 0),
                                       body(-0.25 - 0.16 * tail, 0.445, 0), body(-0.25 - 0.23 * tail, 0.44, 0),
                                       body(-0.25 - 0.30 * tail, 0.43, 0)};
  J[kTail0] = body(-0.25, 0.42, 0);
  for (int k = 1; k < kTailJoints; ++k) J[kTail0 + k] = tail_path[k];
  mesh.loft(flat, procedural::rings_along({{tail_path[0], 0.025, 0.006, only(kTail0)},
                                           {tail_path[1], 0.045, 0.006, only(kTail0 + 1)},
                                           {tail_path[2], 0.05, 0.0055, only(kTail0 + 2)},
                                           {tail_path[3], 0.04, 0.005, only(kTail0 + 3)},
                                           tip(tail_path[4], only(kTail0 + 3))},
                                          Z));
  return d;
}

// Animation: local rotations in the rest pose's axes (facing +X, left along
// -Z); legs swing about z (positive: forward), the right side mirrors the
// left across z = 0 (which leaves rotations about z unchanged).
std::vector<procedural::ClipSpec> clips() {
  using procedural::mirrored;
  using procedural::rotation_x;
  using procedural::rotation_y;
  using procedural::rotation_z;
  const double tau = 2 * M_PI;
  const auto leg = [](ClipFrame& f, int leg0, double swing, double bend, double paw) {
    f.rotations[leg0] = rotation_z(swing);
    f.rotations[leg0 + 1] = rotation_z(-bend);
    f.rotations[leg0 + 2] = rotation_z(paw);
  };
  // Per leg: its phase in the gait, in cycles.
  struct Gait {
    double left_front, right_front, left_back, right_back;
  };
  const auto gait = [=](ClipFrame& f, double t, Gait phase, double swing, double bend, double paw) {
    const std::pair<int, double> legs[] = {{kLeftFront0, phase.left_front},
                                           {kRightFront0, phase.right_front},
                                           {kLeftBack0, phase.left_back},
                                           {kRightBack0, phase.right_back}};
    for (const auto& [leg0, offset] : legs) {
      const double a = tau * (t + offset);
      leg(f, leg0, swing * std::sin(a), bend * std::max(0.0, std::cos(a)), paw * std::max(0.0, std::cos(a)));
    }
  };
  const auto ears = [](ClipFrame& f, const Mat3& left_base, const Mat3& left_tip) {
    f.rotations[kLeftEar0] = left_base;
    f.rotations[kLeftEar0 + 1] = left_tip;
    f.rotations[kRightEar0] = mirrored(left_base, 2);
    f.rotations[kRightEar0 + 1] = mirrored(left_tip, 2);
  };
  const auto wag = [](ClipFrame& f, double lift, double amplitude, double phase) {
    for (int k = 0; k < kTailJoints - 1; ++k)
      f.rotations[kTail0 + k] = rotation_y(amplitude * std::sin(phase - 0.6 * k)) * rotation_z(k == 0 ? lift : 0);
  };
  std::vector<procedural::ClipSpec> specs;
  specs.push_back({"idle", 60, [=](double t, ClipFrame& f) {
                     const double a = tau * t;
                     f.rotations[kChest] = rotation_z(0.02 * std::sin(a));
                     f.rotations[kNeck] = rotation_y(0.3 * std::sin(a)) * rotation_z(0.05 * std::sin(2 * a));
                     f.rotations[kHead] = rotation_z(0.1 * std::sin(2 * a + 1));
                     // Ears flick outward (the left one towards -z) and tilt.
                     ears(f, rotation_x(-0.2 * std::max(0.0, std::sin(3 * a))), rotation_z(0.1 * std::sin(2 * a)));
                     wag(f, 0, 0.25, 2 * a);
                   }});
  specs.push_back({"walk", 40, [=](double t, ClipFrame& f) {
                     const double a = tau * t;
                     gait(f, t, {0.25, 0.75, 0.0, 0.5}, 0.35, 0.45, 0.3);
                     f.rotations[kSpine] = rotation_y(0.05 * std::sin(a));
                     f.rotations[kHead] = rotation_z(0.05 * std::sin(2 * a));
                     ears(f, Mat3::Identity(), rotation_z(0.05 * std::sin(2 * a)));
                     wag(f, 0, 0.15, a);
                     f.root_translation = {0, 0.008 * std::cos(2 * a), 0};
                   }});
  // Out of distribution: a gallop, with larger leg swings and bends, the back
  // flexing, the ears laid back and the tail raised.
  specs.push_back({"run", 30, [=](double t, ClipFrame& f) {
                     const double a = tau * t;
                     gait(f, t, {0.0, 0.08, 0.5, 0.58}, 0.8, 1.0, 0.6);
                     f.rotations[kPelvis] = rotation_z(-0.2 * std::sin(a));
                     f.rotations[kSpine] = rotation_z(0.25 * std::sin(a));
                     f.rotations[kNeck] = rotation_z(-0.3);
                     ears(f, rotation_z(0.6), rotation_z(0.2));
                     wag(f, -0.5, 0.1, a);
                     f.root_translation = {0, 0.04 * std::sin(a), 0};
                   }});
  return specs;
}

}  // namespace

LowPolyCharacter make_animal(uint64_t seed, double variation) {
  Design d = design(seed, variation);
  LowPolyCharacter c;
  const auto mesh = d.mesh.mesh();
  // Normalise to 0.9 from the nose to the tail tip, paws on y = 0.
  const auto x = mesh.vertices.select(1, 0);
  const double scale = 0.9 / (x.max() - x.min()).item<double>();
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
