#pragma once
// Low-poly parts for fskin's game-style test characters (lowpoly_character.h):
// closed tubes lofted through a few polygonal cross-sections, with weights
// painted per ring the way artists paint game rigs (one bone per ring, a
// 50/50 ring at a bend, nothing smoothed). Each loft is one closed genus-0
// part; parts overlap where they join (an arm's root inside the torso), as the
// separate closed parts of real assets do. Internal to src/data/lowpoly.
#include <torch/types.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "fskin/geometry/mesh.h"

namespace fskin::procedural {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// Painted weights of one ring: (bone, weight) pairs summing to 1.
using PaintedWeights = std::vector<std::pair<int, double>>;

// One cross-section: the section polygon placed at `centre` in the plane of
// the unit vectors `u` and `v`, scaled by `half_width` along u and
// `half_thickness` along v. A ring with both scales 0 is a tip: one vertex.
struct LoftRing {
  Vec3 centre;
  Vec3 u, v;
  double half_width = 0, half_thickness = 0;
  PaintedWeights weights;
};

// Cross-section polygons, counter-clockwise in (u, v), vertices on the unit square's or circle's outline.
std::vector<Vec2> regular_section(int sides, double phase = 0);
// A rectangle: the cross-section of flat parts (ears, fins, capes, tails, palms).
std::vector<Vec2> flat_section();

// Axes (u, v) for a ring whose loft runs along `direction`: u is `across`
// made perpendicular to the direction, v completes the right-handed frame
// (u x v points along the direction, so lofts come out counter-clockwise
// seen from outside).
std::pair<Vec3, Vec3> ring_axes(const Vec3& direction, const Vec3& across);

// A ring by its centre, size and weights; rings_along orients it.
struct RingSpec {
  Vec3 centre;
  double half_width = 0, half_thickness = 0;  // both 0: a tip
  PaintedWeights weights;
};
// Rings through the specs' centres, each facing the loft's direction there
// (from its neighbours' centres) with u along `across` (ring_axes).
std::vector<LoftRing> rings_along(const std::vector<RingSpec>& specs, const Vec3& across);

class LoftMesh {
 public:
  explicit LoftMesh(int num_bones) : num_bones_(num_bones) {}

  // A closed tube through `rings` (at least 2; the loft runs from the first to
  // the last, u x v along that way), capped at each end by a vertex at the
  // ring's centre unless the end ring is a tip. Returns the part's index.
  int loft(const std::vector<Vec2>& section, const std::vector<LoftRing>& rings);

  int num_parts() const { return parts_; }
  int64_t num_vertices() const { return static_cast<int64_t>(vertices_.size()); }

  // vertices [V, 3] float32, faces [F, 3] int64 (counter-clockwise seen from outside).
  Mesh mesh() const;
  // Painted weights [V, num_bones] float32, rows summing to 1.
  torch::Tensor weights() const;

 private:
  int64_t add_vertex(const Vec3& position, const PaintedWeights& weights);

  int num_bones_;
  int parts_ = 0;
  std::vector<Vec3> vertices_;
  std::vector<PaintedWeights> vertex_weights_;
  std::vector<std::array<int64_t, 3>> faces_;
};

}  // namespace fskin::procedural
