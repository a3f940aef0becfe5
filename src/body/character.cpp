#include "fskin/body/character.h"

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "fskin/core/error.h"
#include "fskin/geometry/iso_surface.h"
#include "fskin/geometry/mesh_topology.h"

namespace fskin {
namespace {

using Vec3 = Eigen::Vector3d;

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

// Uniform numbers from a fixed algorithm: std::uniform_real_distribution is not
// specified exactly and differs between standard libraries.
class SeededUniform {
 public:
  explicit SeededUniform(uint64_t seed) : engine_(seed) {}
  double symmetric() {  // in [-1, 1)
    return 2.0 * static_cast<double>(engine_() >> 11) * 0x1.0p-53 - 1.0;
  }

 private:
  std::mt19937_64 engine_;
};

// Polynomial smooth minimum (blend radius k): a union with a fillet of size ~k.
double smooth_min(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - 0.25 * h * h * k;
}

// Signed distance (approximate away from the surface) to a capsule whose radius
// changes linearly from ra at a to rb at b.
double capsule_distance(const Vec3& p, const Vec3& a, const Vec3& b, double ra, double rb) {
  const Vec3 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm() - (ra + t * (rb - ra));
}

// Inigo Quilez's ellipsoid bound: exact on the surface, smooth, monotone.
double ellipsoid_distance(const Vec3& p, const Vec3& centre, const Vec3& radii) {
  const Vec3 q = p - centre;
  const double k0 = q.cwiseQuotient(radii).norm();
  const double k1 = q.cwiseQuotient(radii.cwiseProduct(radii)).norm();
  return k1 > 0 ? k0 * (k0 - 1.0) / k1 : -radii.minCoeff();
}

struct Part {
  bool ellipsoid = false;
  Vec3 a, b;  // capsule ends, or the ellipsoid's centre (a) and radii (b)
  double ra = 0, rb = 0;
  double blend = 0;  // smooth-min radius joining it to the parts before it

  double distance(const Vec3& p) const {
    return ellipsoid ? ellipsoid_distance(p, a, b) : capsule_distance(p, a, b, ra, rb);
  }
  void extend(Vec3& lo, Vec3& hi) const {
    const Vec3 r = ellipsoid ? b : Vec3::Constant(std::max(ra, rb));
    const Vec3 c0 = ellipsoid ? a : a.cwiseMin(b), c1 = ellipsoid ? a : a.cwiseMax(b);
    lo = lo.cwiseMin(c0 - r);
    hi = hi.cwiseMax(c1 + r);
  }
};

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

  double body_distance(const Vec3& p) const {
    double d = parts.front().distance(p);
    for (size_t i = 1; i < parts.size(); ++i)
      d = smooth_min(d, parts[i].distance(p), parts[i].blend);
    return d;
  }
  double distance(const Vec3& p) const {
    const double body = body_distance(p);
    return clothed ? smooth_min(body, skirt.distance(p), skirt_blend) : body;
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
  for (auto& part : P) {
    part.a *= s;
    part.b *= s;
    part.ra *= s;
    part.rb *= s;
    part.blend *= s;
  }
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
  const GridBox box{{lo.x(), lo.y(), lo.z()}, {h, h, h}};
  const int64_t W = static_cast<int64_t>(std::ceil((hi.x() - lo.x()) / h)) + 1,
                H = static_cast<int64_t>(std::ceil((hi.y() - lo.y()) / h)) + 1,
                D = static_cast<int64_t>(std::ceil((hi.z() - lo.z()) / h)) + 1;
  auto grid = torch::empty({D, H, W}, torch::kFloat32);
  float* values = grid.data_ptr<float>();
  at::parallel_for(0, D, 1, [&](int64_t begin, int64_t end) {
    for (int64_t k = begin; k < end; ++k)
      for (int64_t j = 0; j < H; ++j)
        for (int64_t i = 0; i < W; ++i) {
          const auto p = box.point(k, j, i);
          values[(k * H + j) * W + i] = static_cast<float>(design.distance(Vec3(p[0], p[1], p[2])));
        }
  });
  // Signed distance: inside is below 0.
  auto mesh = keep_largest_component(iso_surface(grid, box, IsoSurfaceOptions{0.0, false}));
  const auto topology = analyze_topology(mesh);
  FSKIN_CHECK(topology.is_closed_manifold() && topology.euler_characteristic() == 2,
              "built-in character: the mesh at resolution {} is not a closed genus-0 manifold "
              "(boundary edges {}, non-manifold edges {}, Euler characteristic {}); try another "
              "--resolution",
              options.resolution, topology.boundary_edges, topology.non_manifold_edges,
              topology.euler_characteristic());
  return mesh;
}

std::vector<Vec3> to_points(const torch::Tensor& tensor) {
  const auto t = tensor.to(torch::kFloat64).contiguous();
  const double* p = t.data_ptr<double>();
  std::vector<Vec3> out(t.size(0));
  for (size_t i = 0; i < out.size(); ++i) out[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
  return out;
}

// Convex weights over the vertices around `joint` whose weighted mean is the
// joint itself: the maximum-entropy weights closest (in KL divergence) to a
// smooth fall-off `prior`, w_i ~ prior_i exp(lambda . (v_i - joint)), with
// lambda found by Newton's method on the convex dual log sum_i prior_i
// exp(lambda . u_i). Returns false when the joint lies outside the convex hull
// of the candidates (the dual is then unbounded).
bool max_entropy_weights(const std::vector<Vec3>& offsets, const std::vector<double>& prior,
                         std::vector<double>& weights) {
  const size_t n = offsets.size();
  Vec3 lambda = Vec3::Zero();
  const auto evaluate = [&](const Vec3& l, std::vector<double>& w) {
    double max_exponent = -1e300;
    for (size_t i = 0; i < n; ++i) max_exponent = std::max(max_exponent, l.dot(offsets[i]));
    double total = 0;
    for (size_t i = 0; i < n; ++i)
      total += w[i] = prior[i] * std::exp(l.dot(offsets[i]) - max_exponent);
    for (double& x : w) x /= total;
    return std::log(total) + max_exponent;  // the dual objective
  };
  weights.assign(n, 0.0);
  std::vector<double> trial(n);
  double objective = evaluate(lambda, weights);
  for (int iteration = 0; iteration < 100; ++iteration) {
    Vec3 mean = Vec3::Zero();
    for (size_t i = 0; i < n; ++i) mean += weights[i] * offsets[i];
    if (mean.norm() < 1e-7) return true;
    Eigen::Matrix3d covariance = -mean * mean.transpose();
    for (size_t i = 0; i < n; ++i) covariance += weights[i] * offsets[i] * offsets[i].transpose();
    const Vec3 step = -(covariance + 1e-9 * Eigen::Matrix3d::Identity()).ldlt().solve(mean);
    double t = 1.0;  // backtracking line search on the dual
    for (; t > 1e-6; t *= 0.5) {
      const double candidate = evaluate(lambda + t * step, trial);
      if (candidate <= objective + 1e-4 * t * mean.dot(step)) {
        objective = candidate;
        break;
      }
    }
    if (t <= 1e-6) return false;
    lambda += t * step;
    weights.swap(trial);
  }
  return false;
}

// Rows of convex weights over a ring of vertices around each joint that
// regress the designed joint exactly (the ring widens until it surrounds the
// joint), so the rest joints of the clothed and the plain variant agree.
// Hand-written: this is a 3-variable convex problem, no optimiser library needed.
std::vector<std::vector<std::pair<int64_t, double>>> joint_regressor(
    const std::array<Vec3, kNumJoints>& joints, const std::vector<Vec3>& vertices) {
  std::vector<std::vector<std::pair<int64_t, double>>> rows(kNumJoints);
  const int64_t V = static_cast<int64_t>(vertices.size());
  for (int j = 0; j < kNumJoints; ++j) {
    std::vector<double> distance(V);
    double nearest = 1e9;
    for (int64_t v = 0; v < V; ++v) {
      distance[v] = (vertices[v] - joints[j]).norm();
      nearest = std::min(nearest, distance[v]);
    }
    // At coarse resolutions a thin limb's mesh may not surround its joint; the
    // smallest ring's prior weights are used then (the joint moves slightly,
    // and the rest joints are the regressed ones anyway).
    std::vector<std::pair<int64_t, double>> fallback;
    for (double reach : {1.5, 2.0, 3.0, 4.0, 6.0}) {
      const double radius = reach * nearest + 1e-6;  // > 0 even on a vertex
      std::vector<int64_t> ids;
      std::vector<Vec3> offsets;
      std::vector<double> prior, weights;
      for (int64_t v = 0; v < V; ++v)
        if (distance[v] < radius) {
          const double u = distance[v] / radius;
          ids.push_back(v);
          offsets.push_back((vertices[v] - joints[j]) / radius);
          prior.push_back((1 - u * u) * (1 - u * u));
        }
      if (fallback.empty())
        for (size_t i = 0; i < ids.size(); ++i) fallback.emplace_back(ids[i], prior[i]);
      if (!max_entropy_weights(offsets, prior, weights)) continue;
      for (size_t i = 0; i < ids.size(); ++i)
        if (weights[i] > 1e-6) rows[j].emplace_back(ids[i], weights[i]);
      break;
    }
    if (rows[j].empty()) rows[j] = fallback;
    double total = 0;
    for (const auto& entry : rows[j]) total += entry.second;
    for (auto& entry : rows[j]) entry.second /= total;
  }
  return rows;
}

// Vertex neighbours (compressed rows) from the faces.
struct Adjacency {
  std::vector<int64_t> offsets, neighbours;
};
Adjacency mesh_adjacency(const Mesh& mesh) {
  const auto faces = mesh.faces.contiguous();
  const int64_t* f = faces.data_ptr<int64_t>();
  std::vector<std::pair<int64_t, int64_t>> edges;
  for (int64_t i = 0; i < mesh.num_faces(); ++i)
    for (int c = 0; c < 3; ++c) {
      const int64_t a = f[3 * i + c], b = f[3 * i + (c + 1) % 3];
      edges.emplace_back(a, b);
      edges.emplace_back(b, a);
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  Adjacency adjacency;
  adjacency.offsets.assign(mesh.num_vertices() + 1, 0);
  for (const auto& e : edges) {
    ++adjacency.offsets[e.first + 1];
    adjacency.neighbours.push_back(e.second);
  }
  for (int64_t v = 0; v < mesh.num_vertices(); ++v)
    adjacency.offsets[v + 1] += adjacency.offsets[v];
  return adjacency;
}

// Skinning weights [V][J]: softmax of -(distance to each bone's capsule) / sigma,
// then a few averaging passes over the mesh graph (which keep rows >= 0 and
// summing to 1) so that weights vary smoothly across joints.
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
  const double sigma = 0.02 * scale;
  const int64_t V = static_cast<int64_t>(vertices.size());
  std::vector<double> weights(V * kNumJoints);
  for (int64_t v = 0; v < V; ++v) {
    double* w = &weights[v * kNumJoints];
    double nearest = 1e9;
    for (int j = 0; j < kNumJoints; ++j) {
      w[j] =
          capsule_distance(vertices[v], rest[j], ends[j], design.bones[j].r0, design.bones[j].r1);
      nearest = std::min(nearest, w[j]);
    }
    double total = 0;
    for (int j = 0; j < kNumJoints; ++j) {
      w[j] = std::exp(-(w[j] - nearest) / sigma);
      if (w[j] < 1e-4) w[j] = 0;  // keep rows sparse: only nearby bones
      total += w[j];
    }
    for (int j = 0; j < kNumJoints; ++j) w[j] /= total;
  }
  return weights;
}

void smooth_over_mesh(std::vector<double>& weights, const Adjacency& adjacency, int iterations) {
  const int64_t V = static_cast<int64_t>(adjacency.offsets.size()) - 1;
  std::vector<double> next(weights.size());
  for (int it = 0; it < iterations; ++it) {
    for (int64_t v = 0; v < V; ++v) {
      const int64_t begin = adjacency.offsets[v], end = adjacency.offsets[v + 1];
      for (int j = 0; j < kNumJoints; ++j) {
        double sum = 0;
        for (int64_t n = begin; n < end; ++n)
          sum += weights[adjacency.neighbours[n] * kNumJoints + j];
        // Every vertex of a closed mesh has neighbours.
        next[v * kNumJoints + j] =
            0.5 * weights[v * kNumJoints + j] + 0.5 * sum / double(end - begin);
      }
    }
    weights.swap(next);
  }
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
  FSKIN_CHECK(height >= 0.2 && height <= 5.0, "character: --height must be in [0.2, 5] m, got {}",
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

const std::vector<std::string>& smpl_joint_names() {
  static const std::vector<std::string> names = {
      "pelvis",     "left_hip",    "right_hip",    "spine1",      "left_knee",     "right_knee",
      "spine2",     "left_ankle",  "right_ankle",  "spine3",      "left_foot",     "right_foot",
      "neck",       "left_collar", "right_collar", "head",        "left_shoulder", "right_shoulder",
      "left_elbow", "right_elbow", "left_wrist",   "right_wrist", "left_hand",     "right_hand"};
  return names;
}

const std::vector<int64_t>& smpl_parents() {
  static const std::vector<int64_t> parents = {-1, 0, 0, 0,  1,  2,  3,  4,  5,  6,  7,  8,
                                               9,  9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21};
  return parents;
}

BodyModelData make_character(const CharacterOptions& options) {
  options.validate();
  const Design design = design_body(options);
  const double scale = options.height / 1.7;
  const Mesh mesh = mesh_body(design, options);
  const auto vertices = to_points(mesh.vertices);
  const int64_t V = static_cast<int64_t>(vertices.size());

  BodyModelData data;
  data.v_template = mesh.vertices;
  data.faces = mesh.faces;
  data.parents = smpl_parents();
  data.joint_names = smpl_joint_names();

  const auto rows = joint_regressor(design.joints, vertices);
  data.J_regressor = torch::zeros({kNumJoints, V}, torch::kFloat32);
  auto regressor = data.J_regressor.accessor<float, 2>();
  std::array<Vec3, kNumJoints> rest;
  for (int j = 0; j < kNumJoints; ++j) {
    rest[j].setZero();
    for (const auto& [v, w] : rows[j]) {
      regressor[j][v] = static_cast<float>(w);
      rest[j] += w * vertices[v];
    }
  }

  const auto adjacency = mesh_adjacency(mesh);
  auto weights = skinning_weights(design, rest, vertices, scale);
  if (design.clothed) blend_skirt_weights(design, vertices, weights, scale);
  smooth_over_mesh(weights, adjacency, std::max(1, options.resolution / 20));
  data.weights =
      torch::from_blob(weights.data(), {V, kNumJoints}, torch::kFloat64).to(torch::kFloat32);

  // Pose correctives: a bulge along the normal near joint j that grows with
  // 1 - cos(theta_j) = -trace(R_j - I) / 2, i.e. -amplitude / 2 on the three
  // diagonal features of joint j (SMPL feature layout, body_model.h).
  const auto normals = to_points(vertex_normals(mesh));
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
