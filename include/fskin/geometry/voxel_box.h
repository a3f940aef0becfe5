#pragma once
// The axis-aligned canonical box a voxel skinning grid covers (Fast-SNARF
// sec. 4.1). Grid coordinates are u = (x + offset) * scale, in [-1, 1] inside
// the box with align-corners (-1 and 1 are the centres of the first and last
// voxels). Grids are channels-last [D, H, W, C]: D along z, H along y, W along x.
#include <torch/types.h>

#include <array>
#include <string>

namespace fskin {

// Voxel counts; the default is the papers' 64 x 64 x 16 (z has 1/4 resolution
// because a body is flat along z in canonical space).
struct GridShape {
  int64_t depth = 16;   // z
  int64_t height = 64;  // y
  int64_t width = 64;   // x
  int64_t voxels() const { return depth * height * width; }
};

// The most voxels a grid may have along one axis (the training config's limit too).
constexpr int64_t kMaxGridVoxels = 1024;

struct VoxelBox {
  std::array<double, 3> offset{0.0, 0.0, 0.0};  // (x, y, z), added before scaling
  std::array<double, 3> scale{1.0, 1.0, 1.0};   // (x, y, z)
  GridShape shape;

  // The reference layout: offset = -bbox centre, scale = 1 / (max_extent / 2 *
  // padding) on every axis, times z_factor along z. points: [N, 3].
  static VoxelBox around(const torch::Tensor& points, GridShape shape = {}, double padding = 1.2,
                        double z_factor = 4.0);

  // A box for any character, whatever its proportions, size and orientation:
  // the bounding box of points [N, 3] grown on every side by `padding` times
  // its longest side, but by at least `min_padding_voxels` voxels (coarse
  // grids need cells beyond the surface), with `longest_voxels` voxels along
  // the longest side and, along the others, as many as keep the voxel
  // spacing no coarser (at least `min_voxels`), so voxels are close to cubes.
  // For a person in a T-pose this gives about the papers' layout; for a long
  // animal it follows the animal along whichever axis it lies.
  static VoxelBox fit(const torch::Tensor& points, int64_t longest_voxels, double padding = 0.05,
                      int64_t min_voxels = 4, double min_padding_voxels = 1.25);

  // Throws fskin::Error (prefixed with `what`) unless every size is >= 2 and
  // the scales are finite and positive.
  void validate(const std::string& what) const;

  // [..., 3] canonical points -> [..., 3] grid coordinates u.
  torch::Tensor to_grid(const torch::Tensor& points) const;
  // Canonical positions of the voxel centres, [D, H, W, 3].
  torch::Tensor voxel_centres(torch::Dtype dtype = torch::kFloat32) const;
  // Whether points [..., 3] lie inside the box -> bool [...].
  torch::Tensor contains(const torch::Tensor& points) const;
};

// Trilinear interpolation (align-corners, border padding) of a channels-last
// grid [D, H, W, C] at points [M, 3] -> [M, C], or of a batch of grids
// [B, D, H, W, C] at points [B, M, 3] -> [B, M, C]. Differentiable w.r.t.
// both the grid and the points.
torch::Tensor sample_voxels(const torch::Tensor& grid, const VoxelBox& box, const torch::Tensor& points);

}  // namespace fskin
