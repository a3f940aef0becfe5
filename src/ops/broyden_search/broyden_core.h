#pragma once
// The one Broyden solver of fskin (SNARF sec. 3.2, Fast-SNARF sec. 4.1): the
// per-lane iteration towards a root of d(x) = x' as plain functions on plain
// arrays, so the fused Fast-SNARF kernels (CPU and CUDA, residuals from the
// transform grid) and SNARF's search (ops/broyden_lanes: residuals from the
// skinning MLP, evaluated by the caller between steps) run the same code, and
// the unit tests call it directly. No LibTorch here: nvcc compiles it.
#include <cmath>
#include <cstdint>

#include "ops/common/transform_grid.h"

namespace fskin::broyden {

using kernels::GridView;
using kernels::kChannels;

// Thresholds of one search. Norms are squared, as in the Fast-SNARF kernel.
template <typename T>
struct SearchParams {
  int max_iterations;
  T converge_sq;      // stop with success when |d(x) - x'|^2 < converge_sq
  T diverge_sq;       // stop with failure when |d(x) - x'|^2 > diverge_sq (or NaN)
  T denominator_eps;  // SNARF pushes Broyden's denominator away from 0 by this (0: off)
  // On convergence take the quasi-Newton step once more: it costs no residual
  // evaluation and cuts the root error from |J^-1 g| (up to ~1e-4 with the
  // reference threshold) to second order. The papers' code stops without it.
  bool final_step;
};

enum class LaneState : uint8_t { Active = 0, Converged = 1, Failed = 2 };

// The initial inverse Jacobian of a lane from the 3x3 Jacobian at its start
// (row stride `stride`), the identity where that is singular.
template <typename T>
FSKIN_HOST_DEVICE void initial_inverse_jacobian(const T* jacobian, int stride, T jinv[9]) {
  if (!kernels::invert3x3(jacobian, stride, jinv)) {
    for (int i = 0; i < 9; ++i) jinv[i] = (i % 4 == 0) ? T(1) : T(0);
  }
}

// Iteration k of one lane whose residual g = d(x) - x' at x is known: it has
// converged, diverged (or run out of iterations), or takes the quasi-Newton
// step dx = -J^-1 g (Fast-SNARF eq. 7) and stays active.
template <typename T>
FSKIN_HOST_DEVICE_INLINE LaneState broyden_step(T x[3], const T jinv[9], const T g[3], T dx[3], int k,
                                         const SearchParams<T>& params) {
  const T norm_sq = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
  for (int r = 0; r < 3; ++r) dx[r] = -(jinv[3 * r] * g[0] + jinv[3 * r + 1] * g[1] + jinv[3 * r + 2] * g[2]);
  if (norm_sq < params.converge_sq) {
    if (params.final_step) {
      for (int r = 0; r < 3; ++r) x[r] += dx[r];
    }
    return LaneState::Converged;
  }
  if (!(norm_sq <= params.diverge_sq) || k == params.max_iterations) return LaneState::Failed;
  for (int r = 0; r < 3; ++r) x[r] += dx[r];
  return LaneState::Active;
}

// Good Broyden update of the inverse Jacobian (Fast-SNARF eq. 7):
// J^-1 += (dx - J^-1 dg) (dx^T J^-1) / (dx^T J^-1 dg).
template <typename T>
FSKIN_HOST_DEVICE_INLINE void broyden_update(T jinv[9], const T dx[3], const T dg[3], T eps) {
  T u[3], v[3];
  for (int r = 0; r < 3; ++r) u[r] = jinv[3 * r] * dg[0] + jinv[3 * r + 1] * dg[1] + jinv[3 * r + 2] * dg[2];
  for (int col = 0; col < 3; ++col) v[col] = dx[0] * jinv[col] + dx[1] * jinv[3 + col] + dx[2] * jinv[6 + col];
  T denom = dx[0] * u[0] + dx[1] * u[1] + dx[2] * u[2];
  // SNARF's variant: push the denominator away from zero by +-eps.
  if (eps > T(0)) denom += denom >= T(0) ? eps : -eps;
  if (denom == T(0)) return;  // no information along dx; keep the estimate
  const T s = T(1) / denom;
  for (int r = 0; r < 3; ++r) {
    const T w = (dx[r] - u[r]) * s;
    for (int col = 0; col < 3; ++col) jinv[3 * r + col] += w * v[col];
  }
}

// After a step dx: the residual g_new at the new iterate updates J^-1 and
// becomes the lane's residual.
template <typename T>
FSKIN_HOST_DEVICE_INLINE void broyden_absorb(T jinv[9], T g[3], const T dx[3], const T g_new[3], T eps) {
  T dg[3];
  for (int a = 0; a < 3; ++a) {
    dg[a] = g_new[a] - g[a];
    g[a] = g_new[a];
  }
  broyden_update(jinv, dx, dg, eps);
}

// Residual g = T(x) x - x' of the forward skinning equation (SNARF eq. 5,
// Fast-SNARF eq. 6, with T from eq. 14). Returns whether x is inside the box.
template <typename T>
FSKIN_HOST_DEVICE_INLINE bool residual(const GridView<T>& grid, const T x[3], const T x_posed[3], T g[3],
                                T transform[kChannels]) {
  const bool inside = kernels::trilinear_fetch(grid, x, transform);
  kernels::apply_affine(transform, x, g);
  for (int a = 0; a < 3; ++a) g[a] -= x_posed[a];
  return inside;
}

// Outcome of one (point, start) search.
struct SolveResult {
  bool valid;  // converged and inside the grid box
  int iterations;
};

// The solver on the transform grid for `count` <= L starts of one posed point
// at once (in: start points, out: last iterates). The starts advance in
// lockstep so their grid fetches are independent work the CPU overlaps (one
// start alone is a chain of dependent loads); CUDA threads use L = 1. The
// initial inverse Jacobian is the inverse of the blended 3x3 at the start
// (exact for rigid regions; Fast-SNARF uses the transpose of the rotation,
// which breaks with scale). jinv receives the last estimate, which
// Fast-SNARF's approximate gradient reuses (eq. 16-17).
template <typename T, int L>
FSKIN_HOST_DEVICE void solve_lanes(const GridView<T>& grid, const T x_posed[3], T (*x)[3], T (*jinv)[9],
                                   SolveResult* result, int count, const SearchParams<T>& params) {
  T transform[L][kChannels], g[L][3], g_new[L][3], dx[L][3];
  bool inside[L], active[L];
  for (int l = 0; l < count; ++l) {
    inside[l] = residual(grid, x[l], x_posed, g[l], transform[l]);
    initial_inverse_jacobian(transform[l], 4, jinv[l]);
    active[l] = true;
  }
  for (int k = 0;; ++k) {
    bool any = false;
    for (int l = 0; l < count; ++l) {
      if (!active[l]) continue;
      const LaneState state = broyden_step(x[l], jinv[l], g[l], dx[l], k, params);
      if (state == LaneState::Active) {
        any = true;
        continue;
      }
      // `inside` refers to the last evaluated iterate.
      result[l] = {state == LaneState::Converged && inside[l], k};
      active[l] = false;
    }
    if (!any) return;
    if (L > 1) {
      for (int l = 0; l < count; ++l) {
        if (active[l]) kernels::prefetch_cell(grid, x[l]);
      }
    }
    for (int l = 0; l < count; ++l) {
      if (active[l]) inside[l] = residual(grid, x[l], x_posed, g_new[l], transform[l]);
    }
    for (int l = 0; l < count; ++l) {
      if (active[l]) broyden_absorb(jinv[l], g[l], dx[l], g_new[l], params.denominator_eps);
    }
  }
}

// One start (see solve_lanes).
template <typename T>
FSKIN_HOST_DEVICE SolveResult solve(const GridView<T>& grid, const T x_posed[3], T x[3], T jinv[9],
                                    const SearchParams<T>& params) {
  SolveResult result;
  solve_lanes<T, 1>(grid, x_posed, reinterpret_cast<T(*)[3]>(x), reinterpret_cast<T(*)[9]>(jinv), &result, 1,
                    params);
  return result;
}

}  // namespace fskin::broyden
