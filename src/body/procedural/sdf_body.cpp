#include "body/procedural/sdf_body.h"

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/geometry/iso_surface.h"
#include "fskin/geometry/mesh_topology.h"

namespace fskin::procedural {

double smooth_min(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - 0.25 * h * h * k;
}

double capsule_distance(const Vec3& p, const Vec3& a, const Vec3& b, double ra, double rb) {
  const Vec3 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm() - (ra + t * (rb - ra));
}

double ellipsoid_distance(const Vec3& p, const Vec3& centre, const Vec3& radii) {
  const Vec3 q = p - centre;
  const double k0 = q.cwiseQuotient(radii).norm();
  const double k1 = q.cwiseQuotient(radii.cwiseProduct(radii)).norm();
  return k1 > 0 ? k0 * (k0 - 1.0) / k1 : -radii.minCoeff();
}

void Part::extend(Vec3& lo, Vec3& hi) const {
  const Vec3 r = ellipsoid ? b : Vec3::Constant(std::max(ra, rb));
  const Vec3 c0 = ellipsoid ? a : a.cwiseMin(b), c1 = ellipsoid ? a : a.cwiseMax(b);
  lo = lo.cwiseMin(c0 - r);
  hi = hi.cwiseMax(c1 + r);
}

void Part::scale(double s) {
  a *= s;
  b *= s;
  ra *= s;
  rb *= s;
  blend *= s;
}

double union_distance(const std::vector<Part>& parts, const Vec3& p) {
  double d = parts.front().distance(p);
  for (size_t i = 1; i < parts.size(); ++i) d = smooth_min(d, parts[i].distance(p), parts[i].blend);
  return d;
}

Mesh mesh_distance_field(const std::function<double(const Vec3&)>& distance, Vec3 lo, Vec3 hi, double cell,
                         const std::string& what) {
  const GridBox box{{lo.x(), lo.y(), lo.z()}, {cell, cell, cell}};
  const int64_t W = static_cast<int64_t>(std::ceil((hi.x() - lo.x()) / cell)) + 1,
                H = static_cast<int64_t>(std::ceil((hi.y() - lo.y()) / cell)) + 1,
                D = static_cast<int64_t>(std::ceil((hi.z() - lo.z()) / cell)) + 1;
  auto grid = torch::empty({D, H, W}, torch::kFloat32);
  float* values = grid.data_ptr<float>();
  at::parallel_for(0, D, 1, [&](int64_t begin, int64_t end) {
    for (int64_t k = begin; k < end; ++k)
      for (int64_t j = 0; j < H; ++j)
        for (int64_t i = 0; i < W; ++i) {
          const auto p = box.point(k, j, i);
          values[(k * H + j) * W + i] = static_cast<float>(distance(Vec3(p[0], p[1], p[2])));
        }
  });
  // Signed distance: inside is below 0.
  auto mesh = keep_largest_component(iso_surface(grid, box, IsoSurfaceOptions{0.0, false}));
  const auto topology = analyze_topology(mesh);
  FSKIN_CHECK(topology.is_closed_manifold() && topology.euler_characteristic() == 2,
              "{}: the mesh is not a closed genus-0 manifold (boundary edges {}, non-manifold edges {}, Euler "
              "characteristic {}); try another --resolution",
              what, topology.boundary_edges, topology.non_manifold_edges, topology.euler_characteristic());
  return mesh;
}

std::vector<Vec3> to_points(const torch::Tensor& tensor) {
  const auto t = tensor.to(torch::kFloat64).contiguous();
  const double* p = t.data_ptr<double>();
  std::vector<Vec3> out(t.size(0));
  for (size_t i = 0; i < out.size(); ++i) out[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
  return out;
}

namespace {

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

}  // namespace

// Hand-written: this is a 3-variable convex problem, no optimiser library needed.
std::vector<std::vector<std::pair<int64_t, double>>> joint_regressor(const std::vector<Vec3>& joints,
                                                                     const std::vector<Vec3>& vertices) {
  std::vector<std::vector<std::pair<int64_t, double>>> rows(joints.size());
  const int64_t V = static_cast<int64_t>(vertices.size());
  for (size_t j = 0; j < joints.size(); ++j) {
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

RegressedJoints regress_joints(const std::vector<Vec3>& joints, const std::vector<Vec3>& vertices) {
  const auto rows = joint_regressor(joints, vertices);
  const auto J = static_cast<int64_t>(joints.size()), V = static_cast<int64_t>(vertices.size());
  RegressedJoints out{torch::zeros({J, V}, torch::kFloat32), std::vector<Vec3>(joints.size(), Vec3::Zero())};
  auto regressor = out.J_regressor.accessor<float, 2>();
  for (int64_t j = 0; j < J; ++j)
    for (const auto& [v, w] : rows[j]) {
      regressor[j][v] = static_cast<float>(w);
      out.rest[j] += w * vertices[v];
    }
  return out;
}

std::vector<double> capsule_skinning_weights(const std::vector<BoneCapsule>& bones,
                                             const std::vector<Vec3>& vertices, double sigma) {
  const auto J = static_cast<int64_t>(bones.size());
  const int64_t V = static_cast<int64_t>(vertices.size());
  std::vector<double> weights(V * J);
  for (int64_t v = 0; v < V; ++v) {
    double* w = &weights[v * J];
    double nearest = 1e9;
    for (int64_t j = 0; j < J; ++j) {
      const auto& b = bones[j];
      w[j] = capsule_distance(vertices[v], b.start, b.end, b.r0, b.r1);
      nearest = std::min(nearest, w[j]);
    }
    double total = 0;
    for (int64_t j = 0; j < J; ++j) {
      w[j] = std::exp(-(w[j] - nearest) / sigma);
      if (w[j] < 1e-4) w[j] = 0;  // keep rows sparse: only nearby bones
      total += w[j];
    }
    for (int64_t j = 0; j < J; ++j) w[j] /= total;
  }
  return weights;
}

void smooth_over_mesh(std::vector<double>& weights, int64_t num_joints, const Adjacency& adjacency, int iterations) {
  const int64_t V = static_cast<int64_t>(adjacency.offsets.size()) - 1;
  std::vector<double> next(weights.size());
  for (int it = 0; it < iterations; ++it) {
    for (int64_t v = 0; v < V; ++v) {
      const int64_t begin = adjacency.offsets[v], end = adjacency.offsets[v + 1];
      for (int64_t j = 0; j < num_joints; ++j) {
        double sum = 0;
        for (int64_t n = begin; n < end; ++n)
          sum += weights[adjacency.neighbours[n] * num_joints + j];
        // Every vertex of a closed mesh has neighbours.
        next[v * num_joints + j] =
            0.5 * weights[v * num_joints + j] + 0.5 * sum / double(end - begin);
      }
    }
    weights.swap(next);
  }
}

}  // namespace fskin::procedural
