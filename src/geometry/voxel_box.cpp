#include "fskin/geometry/voxel_box.h"

#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

VoxelBox VoxelBox::around(const torch::Tensor& points, GridShape shape, double padding,
                        double z_factor) {
  expect_shape(points, {-1, 3}, "VoxelBox::around: points");
  FSKIN_CHECK(points.size(0) > 0, "VoxelBox::around: points is empty");
  expect_finite(points, "VoxelBox::around: points");
  FSKIN_CHECK(padding > 0 && z_factor > 0, "VoxelBox::around: padding ({}) and z_factor ({}) must be > 0",
              padding, z_factor);
  const auto p = points.detach().to(torch::kCPU, torch::kFloat64);
  const auto lo = std::get<0>(p.min(0)), hi = std::get<0>(p.max(0));
  const auto centre = (lo + hi) / 2;
  const double extent = (hi - lo).max().item<double>();
  FSKIN_CHECK(extent > 0, "VoxelBox::around: points span no volume");
  const double s = 1.0 / (extent / 2 * padding);
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    box.offset[a] = -centre[a].item<double>();
    box.scale[a] = s;
  }
  box.scale[2] *= z_factor;
  box.shape = shape;
  box.validate("VoxelBox::around");
  return box;
}

VoxelBox VoxelBox::fit(const torch::Tensor& points, int64_t longest_voxels, double padding, int64_t min_voxels,
                       double min_padding_voxels) {
  expect_shape(points, {-1, 3}, "VoxelBox::fit: points");
  FSKIN_CHECK(points.size(0) > 0, "VoxelBox::fit: points is empty");
  expect_finite(points, "VoxelBox::fit: points");
  FSKIN_CHECK(longest_voxels >= 2 && min_voxels >= 2 && min_voxels <= longest_voxels &&
                  longest_voxels <= kMaxGridVoxels,
              "VoxelBox::fit: longest_voxels ({}) and min_voxels ({}) must be from 2 to {}, min <= longest",
              longest_voxels, min_voxels, kMaxGridVoxels);
  FSKIN_CHECK(padding >= 0 && std::isfinite(padding), "VoxelBox::fit: padding {} must be >= 0", padding);
  const auto p = points.detach().to(torch::kCPU, torch::kFloat64);
  const auto lo = std::get<0>(p.min(0)), hi = std::get<0>(p.max(0));
  std::array<double, 3> half{}, centre{};
  for (int a = 0; a < 3; ++a) {
    centre[a] = (lo[a].item<double>() + hi[a].item<double>()) / 2;
    half[a] = (hi[a].item<double>() - lo[a].item<double>()) / 2;
  }
  const double longest = 2 * std::max({half[0], half[1], half[2]});
  FSKIN_CHECK(longest > 0, "VoxelBox::fit: points span no volume");
  // A margin of k voxels: p = k * spacing with spacing = (longest + 2 p) / (n - 1),
  // i.e. p = k * longest / (n - 1 - 2 k).
  const double k = min_padding_voxels, cells = static_cast<double>(longest_voxels - 1);
  FSKIN_CHECK(k >= 0 && 2 * k < cells, "VoxelBox::fit: a margin of {} voxels does not fit {} voxels", k, longest_voxels);
  const double margin = std::max(padding * longest, k * longest / (cells - 2 * k));
  for (double& h : half) h += margin;
  // Voxel centres span [-1, 1] (align-corners): n voxels cover 2 half / (n - 1).
  const double spacing = 2 * std::max({half[0], half[1], half[2]}) / static_cast<double>(longest_voxels - 1);
  std::array<int64_t, 3> counts{};
  for (int a = 0; a < 3; ++a) {
    // Flat axes (a 2D set) still get a box: at least one spacing across.
    half[a] = std::max(half[a], spacing);
    const auto n = static_cast<int64_t>(std::ceil(2 * half[a] / spacing - 1e-6)) + 1;
    counts[a] = std::clamp(n, min_voxels, longest_voxels);
  }
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    box.offset[a] = -centre[a];
    box.scale[a] = 1.0 / half[a];
  }
  box.shape = GridShape{counts[2], counts[1], counts[0]};
  box.validate("VoxelBox::fit");
  return box;
}

void VoxelBox::validate(const std::string& what) const {
  FSKIN_CHECK(shape.depth >= 2 && shape.height >= 2 && shape.width >= 2,
              "{}: grid shape (D, H, W) = ({}, {}, {}) must be >= 2 along every axis", what,
              shape.depth, shape.height, shape.width);
  // A grid holds a value per voxel and bone: 1024^3 float weights of one bone are already 4 GiB.
  FSKIN_CHECK(shape.depth <= kMaxGridVoxels && shape.height <= kMaxGridVoxels && shape.width <= kMaxGridVoxels,
              "{}: grid shape (D, H, W) = ({}, {}, {}) must be at most {} along every axis", what, shape.depth,
              shape.height, shape.width, kMaxGridVoxels);
  for (int a = 0; a < 3; ++a) {
    FSKIN_CHECK(std::isfinite(offset[a]) && std::isfinite(scale[a]) && scale[a] > 0,
                "{}: grid box offset/scale along axis {} must be finite with scale > 0 (got {}, {})",
                what, a, offset[a], scale[a]);
  }
}

torch::Tensor VoxelBox::to_grid(const torch::Tensor& points) const {
  const auto o = torch::tensor({offset[0], offset[1], offset[2]}, points.options());
  const auto s = torch::tensor({scale[0], scale[1], scale[2]}, points.options());
  return (points + o) * s;
}

torch::Tensor VoxelBox::voxel_centres(torch::Dtype dtype) const {
  auto axis = [&](int a, int64_t n) {
    return torch::linspace(-1.0, 1.0, n, torch::kFloat64) / scale[a] - offset[a];
  };
  const auto grids = torch::meshgrid({axis(2, shape.depth), axis(1, shape.height), axis(0, shape.width)},
                                     "ij");
  // meshgrid gives (z, y, x); points are (x, y, z).
  return torch::stack({grids[2], grids[1], grids[0]}, -1).to(dtype);
}

torch::Tensor VoxelBox::contains(const torch::Tensor& points) const {
  const auto u = to_grid(points).abs();
  return (u <= 1.0 + 1e-6).all(-1);
}

torch::Tensor sample_voxels(const torch::Tensor& grid, const VoxelBox& box, const torch::Tensor& points) {
  FSKIN_CHECK(grid.dim() == 4 || grid.dim() == 5, "sample_voxels: grid must be [D, H, W, C] or [B, D, H, W, C], got {}",
              shape_string(grid.sizes()));
  const bool batched = grid.dim() == 5;
  const auto g = batched ? grid : grid.unsqueeze(0);
  const auto p = batched ? points : points.unsqueeze(0);
  expect_shape(p, {g.size(0), -1, 3}, "sample_voxels: points");
  FSKIN_CHECK(g.size(1) == box.shape.depth && g.size(2) == box.shape.height && g.size(3) == box.shape.width,
              "sample_voxels: grid {} does not match the box shape (D, H, W) = ({}, {}, {})",
              shape_string(grid.sizes()), box.shape.depth, box.shape.height, box.shape.width);
  const int64_t b = g.size(0), m = p.size(1), c = g.size(4);
  const auto input = g.permute({0, 4, 1, 2, 3});  // [B, C, D, H, W]
  const auto coords = box.to_grid(p.to(g.dtype())).reshape({b, 1, 1, m, 3});
  // interpolation 0 = bilinear (trilinear in 3D), padding 1 = border.
  const auto out = at::grid_sampler(input, coords, 0, 1, /*align_corners=*/true);  // [B, C, 1, 1, M]
  const auto flat = out.reshape({b, c, m}).transpose(1, 2);
  return batched ? flat : flat.squeeze(0);
}

}  // namespace fskin
