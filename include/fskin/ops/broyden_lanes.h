#pragma once
// The Broyden solver of broyden_search (ops/broyden_search/broyden_core.h)
// for callers that evaluate the residual d(x) - x' themselves, batched over
// many lanes between steps: SNARF's search, whose d(x) queries the skinning
// MLP (SNARF Alg. 1 variant 1). Each call runs the solver's per-lane step on
// every lane (CPU at::parallel_for or CUDA), so SNARF and Fast-SNARF share one
// iteration, one convergence rule and one Broyden update. Not differentiable.
#include <torch/types.h>

#include <cstdint>

#include "fskin/ops/broyden_search.h"

namespace fskin {

// Values of BroydenLanes::state.
constexpr uint8_t kLaneActive = 0, kLaneConverged = 1, kLaneFailed = 2;

// P lanes of the solver (all tensors on one device, x's dtype float32/64).
struct BroydenLanes {
  torch::Tensor x;                 // [P, 3] iterates
  torch::Tensor inverse_jacobian;  // [P, 3, 3]
  torch::Tensor residual;          // [P, 3] d(x) - x' at x
  torch::Tensor step;              // [P, 3] the last quasi-Newton step
  torch::Tensor state;             // [P] uint8: 0 active, 1 converged, 2 failed
  torch::Tensor iterations;        // [P] uint8: steps taken
};

// Lanes at x0 [P, 3] with residuals [P, 3] and Jacobians dd/dx [P, 3, 3] at
// x0, inverted (the identity where singular), all active.
BroydenLanes start_broyden_lanes(const torch::Tensor& x0, const torch::Tensor& residual,
                                 const torch::Tensor& jacobian);

// Iteration `iteration` (0-based): each active lane tests its residual
// against options' thresholds and converges, fails, or steps. Returns the
// indices [A] (int64) of the lanes that stepped, whose residuals at their new
// x the caller evaluates next; empty when no lane is active any more.
torch::Tensor step_broyden_lanes(BroydenLanes& lanes, int iteration, const BroydenSearchOptions& options);

// The residuals [A, 3] at the new x of the lanes `stepped` (from
// step_broyden_lanes) update their inverse Jacobians (good Broyden) and residuals.
void update_broyden_lanes(BroydenLanes& lanes, const torch::Tensor& stepped, const torch::Tensor& residual,
                          const BroydenSearchOptions& options);

// The automatic start rule (StartBones::automatic, as broyden_search applies
// it): per point, the `count` starts whose own skinning weight at their own
// rigid start, own_weights [P, S], is largest, ties to the lower index, NaN
// last. -> [P, count] int64 start indices in rank order.
torch::Tensor rank_starts(const torch::Tensor& own_weights, int64_t count);

}  // namespace fskin
