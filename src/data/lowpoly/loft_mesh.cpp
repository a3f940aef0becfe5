#include "data/lowpoly/loft_mesh.h"

#include <torch/torch.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"

namespace fskin::procedural {

std::vector<Vec2> regular_section(int sides, double phase) {
  FSKIN_CHECK(sides >= 3, "regular_section: {} sides (at least 3)", sides);
  std::vector<Vec2> section;
  for (int k = 0; k < sides; ++k) {
    const double angle = phase + 2.0 * M_PI * k / sides;
    section.emplace_back(std::cos(angle), std::sin(angle));
  }
  return section;
}

std::vector<Vec2> flat_section() { return {{1, -1}, {1, 1}, {-1, 1}, {-1, -1}}; }

std::pair<Vec3, Vec3> ring_axes(const Vec3& direction, const Vec3& across) {
  const Vec3 w = direction.normalized();
  const Vec3 u = (across - across.dot(w) * w).normalized();
  FSKIN_CHECK(u.allFinite(), "ring_axes: the across vector is parallel to the loft direction");
  return {u, w.cross(u)};
}

std::vector<LoftRing> rings_along(const std::vector<RingSpec>& specs, const Vec3& across) {
  FSKIN_CHECK(specs.size() >= 2, "rings_along: needs at least 2 rings");
  std::vector<LoftRing> rings;
  for (size_t i = 0; i < specs.size(); ++i) {
    const Vec3 direction = specs[std::min(i + 1, specs.size() - 1)].centre - specs[i == 0 ? 0 : i - 1].centre;
    const auto [u, v] = ring_axes(direction, across);
    rings.push_back({specs[i].centre, u, v, specs[i].half_width, specs[i].half_thickness, specs[i].weights});
  }
  return rings;
}

int64_t LoftMesh::add_vertex(const Vec3& position, const PaintedWeights& weights) {
  double total = 0;
  for (const auto& [bone, w] : weights) {
    FSKIN_CHECK(bone >= 0 && bone < num_bones_ && w >= 0, "loft: painted weight ({}, {}) out of range", bone, w);
    total += w;
  }
  FSKIN_CHECK(std::abs(total - 1.0) < 1e-9, "loft: painted weights sum to {}, not 1", total);
  vertices_.push_back(position);
  vertex_weights_.push_back(weights);
  return static_cast<int64_t>(vertices_.size()) - 1;
}

int LoftMesh::loft(const std::vector<Vec2>& section, const std::vector<LoftRing>& rings) {
  FSKIN_CHECK(section.size() >= 3 && rings.size() >= 2, "loft: needs a section of >= 3 corners and >= 2 rings");
  const int64_t sides = static_cast<int64_t>(section.size());
  const auto is_tip = [](const LoftRing& r) { return r.half_width == 0 && r.half_thickness == 0; };
  // Per ring: the index of its first vertex; a tip has one vertex.
  std::vector<int64_t> first(rings.size());
  for (size_t i = 0; i < rings.size(); ++i) {
    const auto& r = rings[i];
    FSKIN_CHECK(!is_tip(r) || i == 0 || i + 1 == rings.size(), "loft: only the end rings can be tips");
    if (is_tip(r)) {
      first[i] = add_vertex(r.centre, r.weights);
      continue;
    }
    for (int64_t k = 0; k < sides; ++k) {
      const Vec3 p = r.centre + r.half_width * section[k].x() * r.u + r.half_thickness * section[k].y() * r.v;
      const int64_t index = add_vertex(p, r.weights);
      if (k == 0) first[i] = index;
    }
  }
  const auto corner = [&](size_t ring, int64_t k) {
    return is_tip(rings[ring]) ? first[ring] : first[ring] + (k % sides);
  };
  // Sides: the section is counter-clockwise about u x v, the loft's direction,
  // so (a, b, c) = (ring i corner k, corner k + 1, ring i + 1 corner k + 1) faces outward.
  for (size_t i = 0; i + 1 < rings.size(); ++i)
    for (int64_t k = 0; k < sides; ++k) {
      const int64_t a = corner(i, k), b = corner(i, k + 1), c = corner(i + 1, k + 1), d = corner(i + 1, k);
      if (a != b) faces_.push_back({a, b, c});
      if (c != d) faces_.push_back({a, c, d});
    }
  // Caps: a centre vertex fanned to the end rings that are not tips.
  if (!is_tip(rings.front())) {
    const int64_t centre = add_vertex(rings.front().centre, rings.front().weights);
    for (int64_t k = 0; k < sides; ++k) faces_.push_back({centre, corner(0, k + 1), corner(0, k)});
  }
  if (!is_tip(rings.back())) {
    const size_t last = rings.size() - 1;
    const int64_t centre = add_vertex(rings.back().centre, rings.back().weights);
    for (int64_t k = 0; k < sides; ++k) faces_.push_back({centre, corner(last, k), corner(last, k + 1)});
  }
  return parts_++;
}

Mesh LoftMesh::mesh() const {
  auto v = torch::empty({num_vertices(), 3}, torch::kFloat32);
  auto f = torch::empty({static_cast<int64_t>(faces_.size()), 3}, torch::kInt64);
  auto* vp = v.data_ptr<float>();
  for (int64_t i = 0; i < num_vertices(); ++i)
    for (int a = 0; a < 3; ++a) vp[3 * i + a] = static_cast<float>(vertices_[i][a]);
  auto* fp = f.data_ptr<int64_t>();
  for (size_t i = 0; i < faces_.size(); ++i)
    for (int a = 0; a < 3; ++a) fp[3 * i + a] = faces_[i][a];
  return Mesh{v, f, {}};
}

torch::Tensor LoftMesh::weights() const {
  auto w = torch::zeros({num_vertices(), num_bones_}, torch::kFloat32);
  auto* wp = w.data_ptr<float>();
  for (int64_t i = 0; i < num_vertices(); ++i)
    for (const auto& [bone, weight] : vertex_weights_[i]) wp[i * num_bones_ + bone] += static_cast<float>(weight);
  return w;
}

}  // namespace fskin::procedural
