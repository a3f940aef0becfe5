#pragma once
// The plain-pointer math of the Fast-SNARF correspondence search (Fast-SNARF
// sec. 4.1): trilinear fetch of the 12-channel blended-transform grid, 3x3
// inverse, Broyden's update and the convergence tests. Everything is an inline
// function on plain arrays so the CPU kernel, the CUDA kernel and the unit
// tests call the very same code. No LibTorch here: nvcc compiles it without it.
#include <cmath>
#include <cstdint>

#if defined(__CUDACC__)
#define FSKIN_HOST_DEVICE __host__ __device__ __forceinline__
#else
#define FSKIN_HOST_DEVICE inline
#endif

namespace fskin::broyden {

// Channels per voxel: the blended transform T_v = sum_j w_vj B_j as a row-major
// 3x4 matrix [R | t] (Fast-SNARF eq. 15).
constexpr int kChannels = 12;

// One frame of the blended-transform grid, channels-last [D, H, W, 12].
// Voxel coordinates along x (W), y (H), z (D) are `point * scale + shift`, so
// voxel centres sit at integers 0 .. size-1 (align-corners convention).
template <typename T>
struct GridView {
  const T* data;
  int size[3];  // W, H, D (x, y, z order, like the point coordinates)
  T scale[3];
  T shift[3];
};

// Thresholds of one search. Norms are squared, as in the Fast-SNARF kernel.
template <typename T>
struct SearchParams {
  int max_iterations;
  T converge_sq;  // stop with success when |d(x) - x'|^2 < converge_sq
  T diverge_sq;   // stop with failure when |d(x) - x'|^2 > diverge_sq (or NaN)
  T denominator_eps;  // SNARF pushes Broyden's denominator away from 0 by this (0: off)
};

// The voxel cell of point p: lower corner index and fractions (clamped to the
// box, as grid_sample's border padding). Returns whether p lies inside the box.
template <typename T>
FSKIN_HOST_DEVICE bool locate(const GridView<T>& g, const T p[3], int i0[3], T frac[3]) {
  bool inside = true;
  for (int a = 0; a < 3; ++a) {
    T f = p[a] * g.scale[a] + g.shift[a];
    const T hi = static_cast<T>(g.size[a] - 1);
    // A tiny tolerance keeps points exactly on the box faces inside.
    inside = inside && f >= T(-1e-5) && f <= hi + T(1e-5);
    f = f < T(0) ? T(0) : (f > hi ? hi : f);
    f = f == f ? f : T(0);  // NaN -> 0 (the caller rejects NaN residuals)
    int i = static_cast<int>(f);
    i = i > g.size[a] - 2 ? g.size[a] - 2 : i;
    i0[a] = i;
    frac[a] = f - static_cast<T>(i);
  }
  return inside;
}

template <typename T>
FSKIN_HOST_DEVICE const T* cell_base(const GridView<T>& g, const int i0[3], int64_t& row, int64_t& slice) {
  row = static_cast<int64_t>(g.size[0]) * kChannels;
  slice = row * g.size[1];
  return g.data + i0[2] * slice + i0[1] * row + static_cast<int64_t>(i0[0]) * kChannels;
}

// Trilinear interpolation of the 12 channels at point p (Fast-SNARF eq. 14).
// Returns whether p lies inside the box.
template <typename T>
FSKIN_HOST_DEVICE bool trilinear_fetch(const GridView<T>& g, const T p[3], T out[kChannels]) {
  int i0[3];
  T frac[3];
  const bool inside = locate(g, p, i0, frac);
  int64_t row, slice;
  const T* base = cell_base(g, i0, row, slice);
  // Corners (x0,x1) of one row are 24 contiguous values: lerp along x, then y, then z.
  T c[4][kChannels];
  for (int r = 0; r < 4; ++r) {
    const T* v = base + (r >> 1) * slice + (r & 1) * row;
    for (int ch = 0; ch < kChannels; ++ch) c[r][ch] = v[ch] + frac[0] * (v[ch + kChannels] - v[ch]);
  }
  for (int ch = 0; ch < kChannels; ++ch) {
    const T y0 = c[0][ch] + frac[1] * (c[1][ch] - c[0][ch]);
    const T y1 = c[2][ch] + frac[1] * (c[3][ch] - c[2][ch]);
    out[ch] = y0 + frac[2] * (y1 - y0);
  }
  return inside;
}

// Asks the CPU to start loading the cell of p (the four 24-value rows), so
// the fetches of several starts overlap their memory latency. No-op on CUDA.
template <typename T>
FSKIN_HOST_DEVICE void prefetch_cell(const GridView<T>& g, const T p[3]) {
#if !defined(__CUDA_ARCH__) && defined(__GNUC__)
  int i0[3];
  T frac[3];
  locate(g, p, i0, frac);
  int64_t row, slice;
  const T* base = cell_base(g, i0, row, slice);
  for (int r = 0; r < 4; ++r) {
    const char* v = reinterpret_cast<const char*>(base + (r >> 1) * slice + (r & 1) * row);
    __builtin_prefetch(v);
    __builtin_prefetch(v + 2 * kChannels * sizeof(T) - 1);
  }
#endif
}

// y = M x for a row-major 3x4 affine matrix [R | t].
template <typename T>
FSKIN_HOST_DEVICE void apply_affine(const T m[kChannels], const T x[3], T y[3]) {
  for (int r = 0; r < 3; ++r) y[r] = m[4 * r] * x[0] + m[4 * r + 1] * x[1] + m[4 * r + 2] * x[2] + m[4 * r + 3];
}

// Inverse of the 3x3 block of a 3x4 matrix (stride 4) or a plain 3x3 (stride 3)
// by the adjugate. Returns false (and leaves inv untouched) when singular.
template <typename T>
FSKIN_HOST_DEVICE bool invert3x3(const T* m, int stride, T inv[9]) {
  const T a = m[0], b = m[1], c = m[2];
  const T d = m[stride], e = m[stride + 1], f = m[stride + 2];
  const T g = m[2 * stride], h = m[2 * stride + 1], k = m[2 * stride + 2];
  const T co0 = e * k - f * h, co1 = f * g - d * k, co2 = d * h - e * g;
  const T det = a * co0 + b * co1 + c * co2;
  if (!(det > T(1e-12) || det < T(-1e-12))) return false;  // also rejects NaN
  const T s = T(1) / det;
  inv[0] = co0 * s;
  inv[1] = (c * h - b * k) * s;
  inv[2] = (b * f - c * e) * s;
  inv[3] = co1 * s;
  inv[4] = (a * k - c * g) * s;
  inv[5] = (c * d - a * f) * s;
  inv[6] = co2 * s;
  inv[7] = (b * g - a * h) * s;
  inv[8] = (a * e - b * d) * s;
  return true;
}

// Residual g = T(x) x - x' of the forward skinning equation (SNARF eq. 5,
// Fast-SNARF eq. 6, with T from eq. 14). Returns whether x is inside the box.
template <typename T>
FSKIN_HOST_DEVICE bool residual(const GridView<T>& grid, const T x[3], const T x_posed[3], T g[3],
                                T transform[kChannels]) {
  const bool inside = trilinear_fetch(grid, x, transform);
  apply_affine(transform, x, g);
  for (int a = 0; a < 3; ++a) g[a] -= x_posed[a];
  return inside;
}

// Good Broyden update of the inverse Jacobian (Fast-SNARF eq. 7):
// J^-1 += (dx - J^-1 dg) (dx^T J^-1) / (dx^T J^-1 dg).
template <typename T>
FSKIN_HOST_DEVICE void broyden_update(T jinv[9], const T dx[3], const T dg[3], T eps) {
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

// Outcome of one (point, start) search.
struct SolveResult {
  bool valid;  // converged and inside the grid box
  int iterations;
};

// Broyden iterations towards the roots of T(x) x = x' for `count` <= L starts
// of one posed point at once (in: start points, out: last iterates). The
// starts advance in lockstep so their grid fetches are independent work the
// CPU overlaps (one start alone is a chain of dependent loads); CUDA threads
// use L = 1. The initial inverse Jacobian is the inverse of the blended 3x3 at
// the start (exact for rigid regions; Fast-SNARF uses the transpose of the
// rotation, which breaks with scale). jinv receives the last estimate, which
// Fast-SNARF's approximate gradient reuses (eq. 16-17).
template <typename T, int L>
FSKIN_HOST_DEVICE void solve_lanes(const GridView<T>& grid, const T x_posed[3], T (*x)[3], T (*jinv)[9],
                                   SolveResult* result, int count, const SearchParams<T>& params) {
  T transform[L][kChannels], g[L][3], g_new[L][3], dx[L][3];
  bool inside[L], active[L];
  for (int l = 0; l < count; ++l) {
    inside[l] = residual(grid, x[l], x_posed, g[l], transform[l]);
    if (!invert3x3(transform[l], 4, jinv[l])) {
      for (int i = 0; i < 9; ++i) jinv[l][i] = (i % 4 == 0) ? T(1) : T(0);
    }
    active[l] = true;
  }
  for (int k = 0;; ++k) {
    bool any = false;
    for (int l = 0; l < count; ++l) {
      if (!active[l]) continue;
      const T* J = jinv[l];
      const T norm_sq = g[l][0] * g[l][0] + g[l][1] * g[l][1] + g[l][2] * g[l][2];
      for (int r = 0; r < 3; ++r) dx[l][r] = -(J[3 * r] * g[l][0] + J[3 * r + 1] * g[l][1] + J[3 * r + 2] * g[l][2]);
      if (norm_sq < params.converge_sq) {
        // One more quasi-Newton step costs no grid fetch and cuts the root
        // error from |J^-1 g| (up to ~1e-4 with the reference threshold) to
        // second order. `inside` refers to the last evaluated iterate.
        for (int r = 0; r < 3; ++r) x[l][r] += dx[l][r];
        result[l] = {inside[l], k};
        active[l] = false;
      } else if (!(norm_sq <= params.diverge_sq) || k == params.max_iterations) {
        result[l] = {false, k};
        active[l] = false;
      } else {
        for (int r = 0; r < 3; ++r) x[l][r] += dx[l][r];
        any = true;
      }
    }
    if (!any) return;
    if (L > 1) {
      for (int l = 0; l < count; ++l) {
        if (active[l]) prefetch_cell(grid, x[l]);
      }
    }
    for (int l = 0; l < count; ++l) {
      if (active[l]) inside[l] = residual(grid, x[l], x_posed, g_new[l], transform[l]);
    }
    for (int l = 0; l < count; ++l) {
      if (!active[l]) continue;
      T dg[3];
      for (int a = 0; a < 3; ++a) {
        dg[a] = g_new[l][a] - g[l][a];
        g[l][a] = g_new[l][a];
      }
      broyden_update(jinv[l], dx[l], dg, params.denominator_eps);
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

// Score of start bone s for the automatic selection: minus its skinning
// weight w_s at its own rigid start x0 = B_s^-1 x' (nearest voxel of a
// [D, H, W, S] weight grid; +inf outside the box). A bone whose inverse lands
// in the region it drives starts next to a root; one load instead of a
// 96-value trilinear fetch per candidate.
template <typename T>
FSKIN_HOST_DEVICE T start_score(const GridView<T>& grid, const T* weights, int starts, int s, const T x_posed[3],
                                const T start_inverse[kChannels]) {
  T x0[3], frac[3];
  int i0[3];
  apply_affine(start_inverse, x_posed, x0);
  if (!locate(grid, x0, i0, frac)) return T(INFINITY);
  for (int a = 0; a < 3; ++a) i0[a] += frac[a] >= T(0.5);
  const int64_t voxel = (static_cast<int64_t>(i0[2]) * grid.size[1] + i0[1]) * grid.size[0] + i0[0];
  return -weights[voxel * starts + s];
}

// Duplicate removal (Fast-SNARF sec. 4.1): a valid root closer than
// sqrt(tolerance_sq) to an earlier valid root is dropped. Only valid roots
// are compared, and each against the kept ones only.
template <typename T>
FSKIN_HOST_DEVICE void drop_duplicate_roots(const T* x, bool* valid, int count, T tolerance_sq) {
  for (int i = 1; i < count; ++i) {
    if (!valid[i]) continue;
    for (int j = 0; j < i; ++j) {
      if (!valid[j]) continue;
      const T d0 = x[3 * i] - x[3 * j], d1 = x[3 * i + 1] - x[3 * j + 1], d2 = x[3 * i + 2] - x[3 * j + 2];
      if (d0 * d0 + d1 * d1 + d2 * d2 < tolerance_sq) {
        valid[i] = false;
        break;
      }
    }
  }
}

}  // namespace fskin::broyden
