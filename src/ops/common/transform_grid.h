#pragma once
// The Fast-SNARF transform grid as the kernels read it (Fast-SNARF sec. 4.1,
// eq. 13-15): one frame of per-voxel blended transforms [D, H, W, 12], the
// voxel cell of a point, trilinear interpolation of the 12 channels, and the
// 3x4 affine map and 3x3 inverse every op applies. Plain arrays, no LibTorch:
// the CPU kernels, the CUDA kernels (nvcc) and the unit tests include it alike.
#include <cmath>
#include <cstdint>

#include "ops/common/host_device.h"

namespace fskin::kernels {

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

}  // namespace fskin::kernels
