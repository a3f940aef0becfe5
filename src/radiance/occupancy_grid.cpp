#include "fskin/radiance/occupancy_grid.h"

#include <torch/torch.h>

#include <limits>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {

OccupancyGrid OccupancyGrid::filled(std::array<double, 3> lower, std::array<double, 3> upper, int64_t resolution,
                                    bool value) {
  FSKIN_CHECK(resolution >= 1 && resolution <= 1024, "occupancy grid: resolution must be within 1..1024, got {}",
              resolution);
  for (int c = 0; c < 3; ++c)
    FSKIN_CHECK(std::isfinite(lower[c]) && std::isfinite(upper[c]) && upper[c] > lower[c],
                "occupancy grid: the box must be finite and non-empty along every axis");
  OccupancyGrid grid;
  grid.lower = lower;
  grid.upper = upper;
  grid.occupied = torch::full({resolution, resolution, resolution}, value, torch::kBool);
  return grid;
}

torch::Tensor OccupancyGrid::cell_centres() const {
  const int64_t R = resolution();
  std::vector<torch::Tensor> axes;
  for (int c = 0; c < 3; ++c)
    axes.push_back(lower[c] + (torch::arange(R, torch::kFloat32) + 0.5) * ((upper[c] - lower[c]) / R));
  const auto g = torch::meshgrid({axes[2], axes[1], axes[0]}, "ij");  // z, y, x
  return torch::stack({g[2], g[1], g[0]}, -1).reshape({-1, 3});
}

torch::Tensor OccupancyGrid::lookup(const torch::Tensor& points) const {
  FSKIN_CHECK(points.dim() >= 1 && points.size(-1) == 3, "occupancy grid: points must be [..., 3]");
  const int64_t R = resolution();
  const auto flat_points = points.reshape({-1, 3}).to(torch::kFloat32);
  const auto lo = torch::tensor({lower[0], lower[1], lower[2]}, torch::kFloat32);
  const auto size = torch::tensor({upper[0] - lower[0], upper[1] - lower[1], upper[2] - lower[2]}, torch::kFloat32);
  const auto cell = ((flat_points - lo) / size * R).floor().to(torch::kInt64);
  const auto inside = ((cell >= 0) & (cell < R)).all(1);
  const auto c = cell.clamp(0, R - 1);
  const auto flat = (c.select(1, 2) * R + c.select(1, 1)) * R + c.select(1, 0);
  const auto hit = occupied.reshape({-1}).index_select(0, flat) & inside;
  auto shape = points.sizes().vec();
  shape.pop_back();
  return hit.reshape(shape);
}

OccupancyGrid OccupancyGrid::dilated() const {
  OccupancyGrid out = *this;
  const auto grown = torch::max_pool3d(occupied.to(torch::kFloat32).unsqueeze(0).unsqueeze(0), {3, 3, 3}, {1, 1, 1},
                                       {1, 1, 1});
  out.occupied = grown[0][0] > 0.5;
  return out;
}

double OccupancyGrid::occupied_fraction() const {
  return occupied.defined() && occupied.numel() > 0 ? occupied.to(torch::kFloat64).mean().item<double>() : 0.0;
}

std::array<std::array<double, 3>, 2> posed_bounds(const torch::Tensor& voxel_centres, const torch::Tensor& grid_weights,
                                                   const torch::Tensor& bones, double min_weight, double margin) {
  torch::NoGradGuard no_grad;
  FSKIN_CHECK(grid_weights.dim() == 4, "posed_bounds: grid weights must be [D, H, W, J]");
  const int64_t J = grid_weights.size(3);
  expect_shape(bones, {J, 4, 4}, "posed_bounds: bones");
  const auto centres = voxel_centres.reshape({-1, 3}).to(torch::kFloat32).cpu();
  const auto weights = grid_weights.reshape({-1, J}).to(torch::kFloat32).cpu();
  const auto b = bones.to(torch::kFloat32).cpu();
  // Half a voxel around the voxel centres, so each bone's region covers its voxels.
  const auto lo_all = std::get<0>(centres.min(0)), hi_all = std::get<0>(centres.max(0));
  const auto counts = torch::tensor({grid_weights.size(2), grid_weights.size(1), grid_weights.size(0)},
                                    torch::kFloat32);
  const auto half_voxel = (hi_all - lo_all) / (counts - 1).clamp_min(1) / 2;
  std::vector<torch::Tensor> corners;
  for (int64_t j = 0; j < J; ++j) {
    const auto mask = weights.select(1, j) > min_weight;
    if (!mask.any().item<bool>()) continue;
    const auto region = centres.index({mask});
    const auto lo = std::get<0>(region.min(0)) - half_voxel, hi = std::get<0>(region.max(0)) + half_voxel;
    for (int corner = 0; corner < 8; ++corner) {
      const auto p = torch::stack({(corner & 1) ? hi[0] : lo[0], (corner & 2) ? hi[1] : lo[1],
                                   (corner & 4) ? hi[2] : lo[2]});
      corners.push_back(transform_points(b[j], p.unsqueeze(0))[0]);
    }
  }
  FSKIN_CHECK(!corners.empty(), "posed_bounds: no bone has a weight above {} anywhere in the grid", min_weight);
  const auto all = torch::stack(corners);
  const auto lo = std::get<0>(all.min(0)), hi = std::get<0>(all.max(0));
  const double grow = margin * (hi - lo).max().item<double>();
  std::array<std::array<double, 3>, 2> box;
  for (int c = 0; c < 3; ++c) {
    box[0][c] = lo[c].item<double>() - grow;
    box[1][c] = hi[c].item<double>() + grow;
  }
  return box;
}

}  // namespace fskin
