#pragma once
// Fused forward skinning through the Fast-SNARF transform grid: x' = T(x) x
// with T the trilinear interpolation of the per-voxel blended transforms
// (Fast-SNARF eq. 14-15), the deformer's forward map d(x). One pass per point
// (fetch 12 channels, apply the 3x4 matrix) instead of LibTorch's grid_sampler
// plus a batched 3x3 product, which measured 14 ms for 48k re-posed vertices
// (docs/benchmarks.md). Dispatches on the device of its inputs: CPU
// (at::parallel_for) or CUDA (when built with it). Not differentiable: the
// deformer uses it only where gradients are off (evaluation, meshing, re-posing).
// In PyTorch's dispatcher as fskin::grid_forward_skinning(transform_grid,
// box_offset, box_scale, x_canonical) (the box's voxel counts are the grid's
// shape); Python: torch.ops.fskin.grid_forward_skinning.
#include <torch/types.h>

#include "fskin/geometry/voxel_box.h"

namespace fskin {

// transform_grid [B, D, H, W, 12] (row-major 3x4 [R | t] per voxel),
// x_canonical [B, N, 3], both float32 or both float64 on one device -> x' [B, N, 3].
// Points outside the box use the transform of the nearest face (border
// clamping, as sample_voxels).
torch::Tensor grid_forward_skinning(const torch::Tensor& transform_grid, const VoxelBox& box,
                                    const torch::Tensor& x_canonical);

}  // namespace fskin
