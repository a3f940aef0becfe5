#pragma once
// The building blocks of fskin's procedural characters (the built-in humanoid
// and quadruped): bodies as smooth unions of ellipsoids and tapered capsules,
// meshed to one closed genus-0 surface, with joint regressors and skinning
// weights derived from the bones. Internal to src/body.
#include <torch/types.h>

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <random>
#include <utility>
#include <vector>

#include "fskin/geometry/mesh.h"

namespace fskin::procedural {

using Vec3 = Eigen::Vector3d;

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
double smooth_min(double a, double b, double k);
// Signed distance (approximate away from the surface) to a capsule whose radius
// changes linearly from ra at a to rb at b.
double capsule_distance(const Vec3& p, const Vec3& a, const Vec3& b, double ra, double rb);
// Inigo Quilez's ellipsoid bound: exact on the surface, smooth, monotone.
double ellipsoid_distance(const Vec3& p, const Vec3& centre, const Vec3& radii);

struct Part {
  bool ellipsoid = false;
  Vec3 a, b;  // capsule ends, or the ellipsoid's centre (a) and radii (b)
  double ra = 0, rb = 0;
  double blend = 0;  // smooth-min radius joining it to the parts before it

  static Part make_ellipsoid(Vec3 centre, Vec3 radii, double blend) { return Part{true, centre, radii, 0, 0, blend}; }
  static Part make_capsule(Vec3 a, Vec3 b, double ra, double rb, double blend) {
    return Part{false, a, b, ra, rb, blend};
  }
  double distance(const Vec3& p) const {
    return ellipsoid ? ellipsoid_distance(p, a, b) : capsule_distance(p, a, b, ra, rb);
  }
  void extend(Vec3& lo, Vec3& hi) const;
  void scale(double s);
};

// The smooth union of parts, in order.
double union_distance(const std::vector<Part>& parts, const Vec3& p);

// Marching cubes of `distance` (< 0 inside) on cubes of side `cell` over the
// box [lo, hi], keeping the largest component; throws fskin::Error naming
// `what` unless the result is one closed genus-0 manifold.
Mesh mesh_distance_field(const std::function<double(const Vec3&)>& distance, Vec3 lo, Vec3 hi, double cell,
                         const std::string& what);

std::vector<Vec3> to_points(const torch::Tensor& tensor);

// Rows of convex weights over a ring of vertices around each joint that
// regress that joint exactly (the ring widens until it surrounds the joint).
std::vector<std::vector<std::pair<int64_t, double>>> joint_regressor(const std::vector<Vec3>& joints,
                                                                     const std::vector<Vec3>& vertices);

// The joint regressor as a tensor [J, V] and the joints it regresses from the
// vertices (the rest joints of the model).
struct RegressedJoints {
  torch::Tensor J_regressor;
  std::vector<Vec3> rest;
};
RegressedJoints regress_joints(const std::vector<Vec3>& joints, const std::vector<Vec3>& vertices);

// Vertex neighbours (compressed rows) from the faces.
struct Adjacency {
  std::vector<int64_t> offsets, neighbours;
};
Adjacency mesh_adjacency(const Mesh& mesh);

// One joint's region as a capsule from the joint to `end`.
struct BoneCapsule {
  Vec3 start, end;
  double r0 = 0, r1 = 0;
};

// Skinning weights [V * J]: per vertex a softmax of -(distance to each
// bone's capsule) / sigma, entries below 1e-4 dropped (rows stay sparse:
// only nearby bones), rows renormalised.
std::vector<double> capsule_skinning_weights(const std::vector<BoneCapsule>& bones,
                                             const std::vector<Vec3>& vertices, double sigma);

// Averaging passes over the mesh graph on weights [V * J] (rows stay >= 0 and
// sum to 1) so that weights vary smoothly across joints.
void smooth_over_mesh(std::vector<double>& weights, int64_t num_joints, const Adjacency& adjacency, int iterations);

}  // namespace fskin::procedural
