#pragma once
// The kernels' view of frame 0 of a contiguous transform grid [B, D, H, W, 12]
// spanning a VoxelBox (broyden_search and grid_forward_skinning read it alike).
#include <torch/types.h>

#include "fskin/geometry/voxel_box.h"
#include "ops/common/transform_grid.h"

namespace fskin {

template <typename T>
kernels::GridView<T> transform_grid_view(const torch::Tensor& grid, const VoxelBox& box) {
  kernels::GridView<T> g{};
  const int64_t sizes[3] = {box.shape.width, box.shape.height, box.shape.depth};
  for (int k = 0; k < 3; ++k) {
    // Voxel coordinate f = (u + 1) / 2 * (size - 1) with u = (x + offset) * scale.
    const double half = static_cast<double>(sizes[k] - 1) / 2.0;
    g.size[k] = static_cast<int>(sizes[k]);
    g.scale[k] = static_cast<T>(box.scale[k] * half);
    g.shift[k] = static_cast<T>((box.offset[k] * box.scale[k] + 1.0) * half);
  }
  g.data = grid.data_ptr<T>();
  return g;
}

}  // namespace fskin
