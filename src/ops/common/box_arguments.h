#pragma once
// A VoxelBox as the dispatcher schemas pass it: (float[] box_offset,
// float[] box_scale), three values each, (x, y, z); its voxel counts are the
// grid tensor's [B, D, H, W, C] dimensions, so they cannot disagree.
#include <c10/util/ArrayRef.h>
#include <torch/types.h>

#include <vector>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/geometry/voxel_box.h"

namespace fskin {

inline VoxelBox box_from_arguments(c10::ArrayRef<double> offset, c10::ArrayRef<double> scale,
                                   const torch::Tensor& grid, const std::string& op) {
  FSKIN_CHECK(offset.size() == 3 && scale.size() == 3, "{}: box_offset and box_scale need 3 values each, got {} and {}",
              op, offset.size(), scale.size());
  expect_shape(grid, {-1, -1, -1, -1, -1}, op + ": transform_grid");
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    box.offset[a] = offset[a];
    box.scale[a] = scale[a];
  }
  box.shape = {grid.size(1), grid.size(2), grid.size(3)};
  box.validate(op);
  return box;
}

// The C++ entries take a VoxelBox, whose voxel counts the schema drops (they
// become the grid's shape): check them against the grid before the call; the
// kernel checks everything else.
inline void expect_grid_over_box(const torch::Tensor& grid, const VoxelBox& box, const std::string& op) {
  box.validate(op);
  expect_shape(grid, {-1, box.shape.depth, box.shape.height, box.shape.width, -1}, op + ": transform_grid");
}

inline std::vector<double> box_offset_argument(const VoxelBox& box) { return {box.offset.begin(), box.offset.end()}; }
inline std::vector<double> box_scale_argument(const VoxelBox& box) { return {box.scale.begin(), box.scale.end()}; }

}  // namespace fskin
