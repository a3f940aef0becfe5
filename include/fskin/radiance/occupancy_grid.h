#pragma once
// Occupancy grids that let the renderer skip empty space: a boolean grid over
// an axis-aligned box, cells marked where the avatar may have density.
// The canonical grid holds where the radiance field's density exceeds a
// threshold; the posed grid of a frame marks the posed cells whose centre maps
// (through the deformer) to an occupied canonical cell, dilated by one cell so
// parts thinner than a cell are not cut.
#include <torch/types.h>

#include <array>

namespace fskin {

struct OccupancyGrid {
  std::array<double, 3> lower{0, 0, 0}, upper{1, 1, 1};  // x, y, z, metres
  torch::Tensor occupied;  // [R, R, R] bool, indexed [z][y][x]

  int64_t resolution() const { return occupied.defined() ? occupied.size(0) : 0; }
  // A grid of resolution^3 cells over [lower, upper], all `value`.
  static OccupancyGrid filled(std::array<double, 3> lower, std::array<double, 3> upper, int64_t resolution,
                              bool value);
  // Centres of the cells [R^3, 3] (x, y, z), in the order of occupied.reshape(-1).
  torch::Tensor cell_centres() const;
  // Whether points [..., 3] lie in occupied cells (false outside the box) -> bool [...].
  torch::Tensor lookup(const torch::Tensor& points) const;
  // The grid with every cell next to an occupied one (26-neighbourhood) occupied.
  OccupancyGrid dilated() const;
  double occupied_fraction() const;
};

// The box that holds every posed point of a frame: for each bone, its
// canonical region (voxels of the skinning grid where its weight exceeds
// `min_weight`) transformed by the bone, united, grown by `margin` times its
// longest side. LBS blends the bones' images of a point (convex weights), so
// a posed point lies in the hull of what its bones make of it.
// grid_weights [D, H, W, J] over a canonical box (voxel centres
// voxel_centres [D, H, W, 3]), bones [J, 4, 4] canonical -> posed.
std::array<std::array<double, 3>, 2> posed_bounds(const torch::Tensor& voxel_centres,
                                                   const torch::Tensor& grid_weights, const torch::Tensor& bones,
                                                   double min_weight = 0.01, double margin = 0.02);

}  // namespace fskin
