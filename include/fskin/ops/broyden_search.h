#pragma once
// The fused Fast-SNARF correspondence search (Fast-SNARF sec. 4.1, Alg. 1
// variant 2): for every posed point x' and start bone s, start at the rigid
// inverse x0 = B_s^-1 x' and run Broyden's method on T(x) x = x', with T
// trilinearly interpolated from a grid of blended transforms (eq. 13-15). All
// iterations of one (point, start) pair run in registers. Dispatches on the
// device of its inputs: CPU (at::parallel_for) or CUDA (when built with it).
// Not differentiable by itself: the deformers attach the implicit gradient
// (ops/implicit_gradient.h) to the roots it finds. SNARF's search runs the
// same solver with residuals from its MLP (ops/broyden_lanes.h). In PyTorch's
// dispatcher as fskin::broyden_search(transform_grid, box_offset, box_scale,
// x_posed, start_inverses, start_weights, <the options' fields>) -> the
// result's five tensors; Python: torch.ops.fskin.broyden_search.
#include <torch/types.h>

#include "fskin/geometry/voxel_box.h"

namespace fskin {

struct BroydenSearchOptions {
  int max_iterations = 10;
  double converge_sq = 1e-8;  // squared residual norm, (1e-4)^2
  double diverge_sq = 0.25;   // squared residual norm, (0.5)^2
  double denominator_eps = 0.0;
  // One more quasi-Newton step on convergence (ops/broyden_search/broyden_core.h).
  bool final_step = true;
  // Per point, keep only the `num_starts` starts s with the largest weight
  // w_s(B_s^-1 x') (automatic start selection, needs start_weights); -1 keeps all S.
  int64_t num_starts = -1;
  // Also return Broyden's last inverse Jacobian per candidate (for the
  // approximate gradient, Fast-SNARF eq. 16-17).
  bool return_inverse_jacobian = false;
};

struct BroydenSearchResult {
  torch::Tensor x_canonical;       // [B, N, I, 3], last iterate (garbage where invalid)
  torch::Tensor valid;             // [B, N, I] bool: converged and inside the box
  torch::Tensor iterations;        // [B, N, I] uint8: Broyden steps taken
  torch::Tensor start_index;       // [B, N, I] int64: which of the S starts each slot used
  torch::Tensor inverse_jacobian;  // [B, N, I, 3, 3] or undefined
};

// transform_grid: [B, D, H, W, 12] blended transforms (row-major 3x4) over `box`.
// x_posed: [B, N, 3]. start_inverses: [B, S, 4, 4] (posed -> canonical rigid
// inverses of the start bones). start_weights: [D, H, W, S] skinning weights
// of the start bones, only read when options.num_starts < S. Float32 or
// float64; all on one device.
BroydenSearchResult broyden_search(const torch::Tensor& transform_grid, const VoxelBox& box,
                                   const torch::Tensor& x_posed, const torch::Tensor& start_inverses,
                                   const BroydenSearchOptions& options,
                                   const torch::Tensor& start_weights = {});

}  // namespace fskin
