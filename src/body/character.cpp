#include "fskin/body/character.h"

#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "body/procedural/sdf_body.h"
#include "fskin/core/error.h"
#include "fskin/geometry/mesh_topology.h"

namespace fskin {
namespace {

using procedural::Part;
using procedural::SeededUniform;
using procedural::Vec3;

enum Joint : int {
  kPelvis,
  kLeftHip,
  kRightHip,
  kSpine1,
  kLeftKnee,
  kRightKnee,
  kSpine2,
  kLeftAnkle,
  kRightAnkle,
  kSpine3,
  kLeftFoot,
  kRightFoot,
  kNeck,
  kLeftCollar,
  kRightCollar,
  kHead,
  kLeftShoulder,
  kRightShoulder,
  kLeftElbow,
  kRightElbow,
  kLeftWrist,
  kRightWrist,
  kLeftHand,
  kRightHand,
  kNumJoints
};

// In SMPL's order every right joint directly follows its left twin.
int sided(int left_joint, int side) { return side > 0 ? left_joint : left_joint + 1; }

// A solid elliptic truncated cone from the waist (top) to the hem, flaring out.
struct Skirt {
  double top_y, hem_y, top_radius, hem_radius, depth_ratio, rounding;

  double distance(const Vec3& p) const {
    const double t = std::clamp((top_y - p.y()) / (top_y - hem_y), 0.0, 1.0);
    const double radius = top_radius + t * (hem_radius - top_radius);
    const double slope = (hem_radius - top_radius) / (top_y - hem_y);
    const double radial = std::hypot(p.x(), p.z() / depth_ratio);
    const double side = (radial - radius) / std::sqrt(1.0 + slope * slope);
    const double cap = std::max(p.y() - top_y, hem_y - p.y());
    const double outside = std::hypot(std::max(side, 0.0), std::max(cap, 0.0));
    return outside + std::min(std::max(side, cap), 0.0) - rounding;
  }
};

// Each joint's bone, from the joint to its child (or to a tip for leaves), as
// a capsule: the region whose vertices move with that joint.
struct Bone {
  Vec3 end;  // the start is the joint
  double r0 = 0, r1 = 0;
};

struct Design {
  std::array<Vec3, kNumJoints> joints;
  std::array<Bone, kNumJoints> bones;
  std::vector<Part> parts;  // the body, in union order
  bool clothed = false;
  Skirt skirt{};
  double skirt_blend = 0;

  double distance(const Vec3& p) const {
    const double body = procedural::union_distance(parts, p);
    return clothed ? procedural::smooth_min(body, skirt.distance(p), skirt_blend) : body;
  }
};

// Proportions in metres for a body about 1.74 m tall before the final scaling
// to options.height; left is +x, so `side` is +1 for left and -1 for right.
Design design_body(const CharacterOptions& o) {
  SeededUniform uniform(o.seed);
  const auto vary = [&](double multiplier) {
    return multiplier * (1.0 + o.variation * uniform.symmetric());
  };
  const double girth = vary(o.girth), shoulders = vary(o.shoulder_width), hips = vary(o.hip_width),
               arms = vary(o.arm_length), legs = vary(o.leg_length), head = vary(o.head_size),
               torso = vary(1.0);
  Design d;
  auto& J = d.joints;
  const double ankle_y = 0.085, knee_y = ankle_y + 0.41 * legs, hip_y = knee_y + 0.40 * legs;
  J[kPelvis] = {0, hip_y + 0.075, -0.01};
  J[kSpine1] = J[kPelvis] + Vec3(0, 0.11 * torso, 0.0);
  J[kSpine2] = J[kSpine1] + Vec3(0, 0.13 * torso, 0.01);
  J[kSpine3] = J[kSpine2] + Vec3(0, 0.06 * torso, 0.01);
  J[kNeck] = J[kSpine3] + Vec3(0, 0.20 * torso, -0.015);
  J[kHead] = J[kNeck] + Vec3(0, 0.075, 0.02);
  for (int side : {+1, -1}) {
    const auto at = [side](int left_joint) { return sided(left_joint, side); };
    J[at(kLeftHip)] = {side * 0.10 * hips, hip_y, 0.0};
    J[at(kLeftKnee)] = {side * 0.105 * hips, knee_y, 0.01};
    J[at(kLeftAnkle)] = {side * 0.11 * hips, ankle_y, -0.01};
    J[at(kLeftFoot)] = {side * 0.115 * hips, 0.03, 0.10};
    J[at(kLeftCollar)] = J[kSpine3] + Vec3(side * 0.075 * shoulders, 0.12 * torso, -0.005);
    J[at(kLeftShoulder)] = {side * 0.175 * shoulders, J[kNeck].y() - 0.055, -0.015};
    J[at(kLeftElbow)] = J[at(kLeftShoulder)] + Vec3(side * 0.255 * arms, 0, 0);
    J[at(kLeftWrist)] = J[at(kLeftElbow)] + Vec3(side * 0.245 * arms, 0, 0);
    J[at(kLeftHand)] = J[at(kLeftWrist)] + Vec3(side * 0.085 * arms, 0, 0);
  }

  const auto ellipsoid = [](Vec3 centre, Vec3 radii, double blend) {
    return Part{true, centre, radii, 0, 0, blend};
  };
  const auto capsule = [](Vec3 a, Vec3 b, double ra, double rb, double blend) {
    return Part{false, a, b, ra, rb, blend};
  };
  const double g = girth;
  auto& P = d.parts;
  P.push_back(ellipsoid({0, hip_y + 0.035, -0.015}, {0.165 * hips * g, 0.11, 0.115 * g}, 0));
  P.push_back(ellipsoid(J[kSpine1] + Vec3(0, 0.03, 0.005),
                        {0.145 * 0.5 * (hips + shoulders) * g, 0.13, 0.105 * g}, 0.08));
  P.push_back(
      ellipsoid(J[kSpine3] + Vec3(0, 0.02, 0), {0.17 * shoulders * g, 0.16, 0.115 * g}, 0.08));
  P.push_back(capsule(J[kSpine3] + Vec3(0, 0.12, -0.01), J[kHead] + Vec3(0, 0.02, 0), 0.055 * g,
                      0.05 * g, 0.04));
  P.push_back(
      ellipsoid(J[kHead] + Vec3(0, 0.085 * head, 0.005), Vec3(0.078, 0.105, 0.095) * head, 0.04));
  const double head_top = P.back().a.y() + P.back().b.y();
  for (int side : {+1, -1}) {
    const auto at = [side](int left_joint) { return sided(left_joint, side); };
    const Vec3 x(side, 0, 0);
    P.push_back(
        capsule({0, J[kNeck].y() - 0.03, -0.015}, J[at(kLeftShoulder)], 0.06 * g, 0.055 * g, 0.05));
    P.push_back(capsule(J[at(kLeftShoulder)], J[at(kLeftElbow)], 0.052 * g, 0.042 * g, 0.03));
    P.push_back(capsule(J[at(kLeftElbow)], J[at(kLeftWrist)], 0.042 * g, 0.030 * g, 0.02));
    P.push_back(ellipsoid(J[at(kLeftWrist)] + 0.085 * arms * x + Vec3(0, 0, 0.005),
                          {0.095 * arms, 0.024 * g, 0.048 * g}, 0.02));
    P.push_back(capsule(J[at(kLeftWrist)] + 0.025 * x + Vec3(0, -0.005, 0.03),
                        J[at(kLeftWrist)] + 0.075 * x + Vec3(0, -0.005, 0.07), 0.016 * g, 0.014 * g,
                        0.015));
    P.push_back(capsule(J[at(kLeftHip)], J[at(kLeftKnee)], 0.078 * g, 0.056 * g, 0.04));
    P.push_back(capsule(J[at(kLeftKnee)], J[at(kLeftAnkle)], 0.055 * g, 0.038 * g, 0.03));
    P.push_back(capsule({J[at(kLeftAnkle)].x(), 0.04, -0.045},
                        {J[at(kLeftFoot)].x() + side * 0.005, 0.03, 0.17}, 0.042 * g, 0.03 * g,
                        0.03));
  }
  // Bones: joint -> child (the SMPL joint whose frame moves the region).
  const auto bone = [&](int joint, const Vec3& end, double r0, double r1) {
    d.bones[joint] = Bone{end, r0 * g, r1 * g};
  };
  bone(kPelvis, J[kSpine1], 0.15, 0.15);
  bone(kSpine1, J[kSpine2], 0.13, 0.13);
  bone(kSpine2, J[kSpine3], 0.14, 0.14);
  bone(kSpine3, J[kNeck], 0.13, 0.13);
  bone(kNeck, J[kHead], 0.05, 0.05);
  bone(kHead, J[kHead] + Vec3(0, 0.19 * head, 0), 0.09, 0.09);
  for (int side : {+1, -1}) {
    const auto at = [side](int left_joint) { return sided(left_joint, side); };
    bone(at(kLeftCollar), J[at(kLeftShoulder)], 0.06, 0.06);
    bone(at(kLeftShoulder), J[at(kLeftElbow)], 0.05, 0.042);
    bone(at(kLeftElbow), J[at(kLeftWrist)], 0.042, 0.03);
    bone(at(kLeftWrist), J[at(kLeftHand)], 0.035, 0.035);
    bone(at(kLeftHand), J[at(kLeftHand)] + Vec3(side * 0.1 * arms, 0, 0), 0.03, 0.03);
    bone(at(kLeftHip), J[at(kLeftKnee)], 0.078, 0.056);
    bone(at(kLeftKnee), J[at(kLeftAnkle)], 0.055, 0.038);
    bone(at(kLeftAnkle), J[at(kLeftFoot)], 0.04, 0.04);
    bone(at(kLeftFoot), J[at(kLeftFoot)] + Vec3(0, 0, 0.07), 0.03, 0.03);
  }
  d.clothed = o.clothed;
  d.skirt =
      Skirt{J[kSpine1].y() - 0.02, knee_y + 0.10, 0.12 * hips * g, 0.29 * hips * g, 0.8, 0.01};
  d.skirt_blend = 0.02;

  // Scale everything so the top of the head is at options.height.
  const double s = o.height / head_top;
  for (auto& j : J) j *= s;
  for (auto& b : d.bones) {
    b.end *= s;
    b.r0 *= s;
    b.r1 *= s;
  }
  for (auto& part : P) part.scale(s);
  for (double* v : {&d.skirt.top_y, &d.skirt.hem_y, &d.skirt.top_radius, &d.skirt.hem_radius,
                    &d.skirt.rounding, &d.skirt_blend})
    *v *= s;
  return d;
}

Mesh mesh_body(const Design& design, const CharacterOptions& options) {
  const double h = options.height / options.resolution;
  Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
  for (const auto& part : design.parts) part.extend(lo, hi);
  if (design.clothed) {
    const Skirt& s = design.skirt;
    lo = lo.cwiseMin(Vec3(-s.hem_radius, s.hem_y, -s.hem_radius * s.depth_ratio));
    hi = hi.cwiseMax(Vec3(s.hem_radius, s.top_y, s.hem_radius * s.depth_ratio));
  }
  // Smooth unions only grow the shape by a fraction of the blend radius.
  lo -= Vec3::Constant(3 * h + 0.03 * options.height);
  hi += Vec3::Constant(3 * h + 0.03 * options.height);
  return procedural::mesh_distance_field([&](const Vec3& p) { return design.distance(p); }, lo, hi, h,
                                         fmt::format("built-in character at resolution {}", options.resolution));
}

// Skinning weights [V][J] from the bones' capsules along the regressed joints.
std::vector<double> skinning_weights(const Design& design, const std::array<Vec3, kNumJoints>& rest,
                                     const std::vector<Vec3>& vertices, double scale) {
  const auto& parents = smpl_parents();
  std::vector<std::vector<int>> children(kNumJoints);
  for (int j = 1; j < kNumJoints; ++j) children[parents[j]].push_back(j);
  // Bones follow the regressed joints: a bone ends at its child's rest joint,
  // or, for leaves, keeps its designed length and direction.
  std::array<Vec3, kNumJoints> ends;
  for (int j = 0; j < kNumJoints; ++j) {
    const Bone& bone = design.bones[j];
    int child = -1;
    for (int c : children[j])
      if ((design.joints[c] - bone.end).norm() < 1e-9) child = c;
    ends[j] = child >= 0 ? rest[child] : rest[j] + (bone.end - design.joints[j]);
  }
  std::vector<procedural::BoneCapsule> capsules;
  for (int j = 0; j < kNumJoints; ++j) capsules.push_back({rest[j], ends[j], design.bones[j].r0, design.bones[j].r1});
  return procedural::capsule_skinning_weights(capsules, vertices, 0.02 * scale);
}

// How much a vertex belongs to the skirt: 1 on its surface, fading out over
// 2 cm (the fillets to the torso and the legs); where the hips touch the skirt
// from inside, the vertex still follows the cloth. `height` is 0 at the waist
// and 1 at the hem.
struct SkirtMembership {
  double on_skirt, height;
};

SkirtMembership skirt_membership(const Skirt& skirt, const Vec3& p, double scale) {
  const double s = std::clamp(1.0 - skirt.distance(p) / (0.02 * scale), 0.0, 1.0);
  return {s * s * (3 - 2 * s),
          std::clamp((skirt.top_y - p.y()) / (skirt.top_y - skirt.hem_y), 0.0, 1.0)};
}

// The skirt moves like cloth on the legs: pelvis at the waist, blending into
// the hips and then partly the knees towards the hem, left/right by x.
void blend_skirt_weights(const Design& design, const std::vector<Vec3>& vertices,
                         std::vector<double>& weights, double scale) {
  for (size_t v = 0; v < vertices.size(); ++v) {
    const Vec3& p = vertices[v];
    const auto [on_skirt, t] = skirt_membership(design.skirt, p, scale);
    if (on_skirt <= 0) continue;
    const double left = 1.0 / (1.0 + std::exp(-p.x() / (0.03 * scale)));
    std::array<double, kNumJoints> cloth{};
    cloth[kPelvis] = 1 - t;
    cloth[kLeftHip] = t * (1 - 0.35 * t) * left;
    cloth[kRightHip] = t * (1 - 0.35 * t) * (1 - left);
    cloth[kLeftKnee] = 0.35 * t * t * left;
    cloth[kRightKnee] = 0.35 * t * t * (1 - left);
    double* w = &weights[v * kNumJoints];
    for (int j = 0; j < kNumJoints; ++j) w[j] = (1 - on_skirt) * w[j] + on_skirt * cloth[j];
  }
}

}  // namespace

void CharacterOptions::validate() const {
  FSKIN_CHECK(resolution >= 32 && resolution <= 512,
              "character: --resolution must be in [32, 512], got {}", resolution);
  FSKIN_CHECK(height >= 0.01 && height <= 100.0, "character: --height must be in [0.01, 100] m, got {}",
              height);
  const std::pair<const char*, double> proportions[] = {
      {"girth", girth},           {"shoulder-width", shoulder_width}, {"hip-width", hip_width},
      {"arm-length", arm_length}, {"leg-length", leg_length},         {"head-size", head_size}};
  for (const auto& [name, value] : proportions)
    FSKIN_CHECK(value >= 0.7 && value <= 1.3, "character: --{} must be in [0.7, 1.3], got {}", name,
                value);
  FSKIN_CHECK(variation >= 0.0 && variation <= 0.1,
              "character: --variation must be in [0, 0.1], got {}", variation);
}

BodyModelData make_character(const CharacterOptions& options) {
  options.validate();
  const Design design = design_body(options);
  const double scale = options.height / 1.7;
  const Mesh mesh = mesh_body(design, options);
  const auto vertices = procedural::to_points(mesh.vertices);
  const int64_t V = static_cast<int64_t>(vertices.size());

  BodyModelData data;
  data.v_template = mesh.vertices;
  data.faces = mesh.faces;
  data.parents = smpl_parents();
  data.joint_names = smpl_joint_names();

  auto regressed = procedural::regress_joints({design.joints.begin(), design.joints.end()}, vertices);
  data.J_regressor = regressed.J_regressor;
  std::array<Vec3, kNumJoints> rest;
  std::copy(regressed.rest.begin(), regressed.rest.end(), rest.begin());

  const auto adjacency = procedural::mesh_adjacency(mesh);
  auto weights = skinning_weights(design, rest, vertices, scale);
  if (design.clothed) blend_skirt_weights(design, vertices, weights, scale);
  procedural::smooth_over_mesh(weights, kNumJoints, adjacency, std::max(1, options.resolution / 20));
  data.weights =
      torch::from_blob(weights.data(), {V, kNumJoints}, torch::kFloat64).to(torch::kFloat32);

  // Pose correctives: a bulge along the normal near joint j that grows with
  // 1 - cos(theta_j) = -trace(R_j - I) / 2, i.e. -amplitude / 2 on the three
  // diagonal features of joint j (SMPL feature layout, body_model.h).
  const auto normals = procedural::to_points(vertex_normals(mesh));
  // Amplitude and Gaussian radius (metres at 1.7 m): the radius reaches the
  // surface around the joint (deep inside the torso, close under the skin at
  // the elbows).
  struct Bulge {
    int joint;
    double amplitude, radius;
  };
  const Bulge bulges[] = {{kLeftElbow, 0.012, 0.045},   {kRightElbow, 0.012, 0.045},
                          {kLeftKnee, 0.014, 0.05},     {kRightKnee, 0.014, 0.05},
                          {kLeftShoulder, 0.006, 0.07}, {kRightShoulder, 0.006, 0.07},
                          {kLeftHip, 0.006, 0.09},      {kRightHip, 0.006, 0.09},
                          {kSpine1, 0.005, 0.12},       {kSpine2, 0.005, 0.12}};
  data.posedirs = torch::zeros({V, 3, 9 * (kNumJoints - 1)}, torch::kFloat32);
  auto posedirs = data.posedirs.accessor<float, 3>();
  for (const auto& [joint, amplitude, radius] : bulges)
    for (int64_t v = 0; v < V; ++v) {
      const double r2 = (vertices[v] - rest[joint]).squaredNorm() / std::pow(radius * scale, 2);
      if (r2 > 16) continue;
      const double bulge = amplitude * scale * std::exp(-0.5 * r2);
      for (int c = 0; c < 3; ++c)
        for (int diagonal : {0, 4, 8})
          posedirs[v][c][9 * (joint - 1) + diagonal] +=
              static_cast<float>(-0.5 * bulge * normals[v][c]);
    }

  // The skirt's pose-dependent flare: the hem swings outward, away from the
  // skirt's axis, by 6 cm (at 1.7 m) per unit of 1 - cos(theta) of either hip,
  // growing with the square of the height below the waist. Both hips widen the
  // whole hem, so raising the left leg also lifts the right side of the skirt.
  // This is what LBS cannot do with any pose-free weights (a hip's rotation
  // about x moves points only in y and z; here it moves them in x too), and
  // it is what the pose-conditioned methods (SNARF, INS) are there to learn.
  if (design.clothed) {
    const Skirt& skirt = design.skirt;
    const double flare = 0.06 * scale;
    for (int64_t v = 0; v < V; ++v) {
      const auto [on_skirt, t] = skirt_membership(skirt, vertices[v], scale);
      if (on_skirt <= 0) continue;
      const Vec3 outward =
          flare * on_skirt * t * t * Vec3(vertices[v].x(), 0, vertices[v].z()) / skirt.hem_radius;
      for (int joint : {kLeftHip, kRightHip})
        for (int c = 0; c < 3; ++c)
          for (int diagonal : {0, 4, 8})
            posedirs[v][c][9 * (joint - 1) + diagonal] += static_cast<float>(-0.5 * outward[c]);
    }
  }

  // Shape directions: height (+3 % per unit, about the soles) and girth (+1 cm
  // along the normal per unit).
  data.shapedirs = torch::zeros({V, 3, 2}, torch::kFloat32);
  auto shapedirs = data.shapedirs.accessor<float, 3>();
  for (int64_t v = 0; v < V; ++v) {
    shapedirs[v][1][0] = static_cast<float>(0.03 * vertices[v].y());
    for (int c = 0; c < 3; ++c)
      shapedirs[v][c][1] = static_cast<float>(0.01 * scale * normals[v][c]);
  }
  return data;
}

BodyModel make_character_model(const CharacterOptions& options) {
  return BodyModel(make_character(options), "built-in character");
}

}  // namespace fskin
