#pragma once
// Iso-surface extraction: the level set of a scalar field sampled on a regular
// grid, as a closed, manifold, consistently oriented triangle mesh.
//
// Convention: a sample is *inside* when its value is above the iso value
// (occupancy probabilities, logits: inside = 1 / positive, docs/conventions.md);
// set `inside_above = false` for signed distances (inside = negative). Faces are
// counter-clockwise seen from outside, so face normals point from inside to
// outside. The mesh is closed wherever the field is outside on the grid's
// border; a shape cut by the border is open there.
#include <torch/types.h>

#include <array>
#include <functional>

#include "fskin/geometry/mesh.h"

namespace fskin {

// Sample (k, j, i) of a [D, H, W] grid (D along z, H along y, W along x, as the
// voxel grids of docs/conventions.md) lies at
//   origin + (i * voxel_size[0], j * voxel_size[1], k * voxel_size[2]).
struct GridBox {
  std::array<double, 3> origin{0.0, 0.0, 0.0};      // x, y, z of sample (0, 0, 0), metres
  std::array<double, 3> voxel_size{1.0, 1.0, 1.0};  // spacing along x, y, z, metres

  // The grid with dims {D, H, W} whose corner samples lie on the corners of the
  // box [lo, hi] (x, y, z), as align-corners grids do.
  static GridBox spanning(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                          const std::array<int64_t, 3>& dims) {
    GridBox box{lo, {}};
    for (int axis = 0; axis < 3; ++axis)
      box.voxel_size[axis] = (hi[axis] - lo[axis]) / static_cast<double>(dims[2 - axis] - 1);
    return box;
  }

  std::array<double, 3> point(int64_t k, int64_t j, int64_t i) const {
    return {origin[0] + static_cast<double>(i) * voxel_size[0],
            origin[1] + static_cast<double>(j) * voxel_size[1],
            origin[2] + static_cast<double>(k) * voxel_size[2]};
  }
};

struct IsoSurfaceOptions {
  double iso = 0.0;
  bool inside_above = true;  // inside = value > iso (false: value < iso)
};

// values: [D, H, W] floating point, D, H, W >= 2, finite. Every grid edge whose
// ends lie on different sides gets exactly one vertex (linear interpolation),
// shared by all faces that use it: no duplicate vertices. Deterministic.
Mesh iso_surface(const torch::Tensor& values, const GridBox& box,
                 const IsoSurfaceOptions& options = {});

// A field evaluated on batches of points: [N, 3] float32 (x, y, z) -> [N] values.
using ScalarField = std::function<torch::Tensor(const torch::Tensor& points)>;

// The field sampled on the grid of `box` with dims {D, H, W}, calling `field`
// with at most `batch_size` points at a time -> [D, H, W] float32.
torch::Tensor sample_grid(const ScalarField& field, const GridBox& box,
                          const std::array<int64_t, 3>& dims, int64_t batch_size = 1 << 16);

// sample_grid followed by iso_surface.
Mesh iso_surface(const ScalarField& field, const GridBox& box, const std::array<int64_t, 3>& dims,
                 const IsoSurfaceOptions& options = {});

}  // namespace fskin
