#pragma once
// Raw-pointer arguments of the hash encoding's launches, the per-point core
// both devices run (the cell of a level, its 8 vertices' table rows and
// trilinear weights), and the device kernels (cpu/, cuda/). Torch-free so nvcc
// compiles it.
#include <cstdint>

#include "ops/common/host_device.h"

namespace fskin::hash_grid {

constexpr int kMaxLevels = 32;

template <typename T>
struct EncodingLaunch {
  const T* positions;  // [N, 3]
  const T* table;      // [L, S, F]
  int64_t points, levels, features, table_size;
  int64_t resolution[kMaxLevels];  // N_l cells per axis
  bool hashed[kMaxLevels];
  T* out;                    // forward: [N, L * F]
  const T* grad_out;         // backward: [N, L * F]
  T* grad_table;             // backward: [L, S, F] (accumulated), or null
  T* grad_positions;         // backward: [N, 3], or null
};

// Table row of grid vertex (x, y, z) of a level with `resolution` cells per axis.
FSKIN_HOST_DEVICE int64_t vertex_row(int64_t x, int64_t y, int64_t z, int64_t resolution, bool hashed,
                                     int64_t table_size) {
  if (!hashed) {
    const int64_t side = resolution + 1;
    return x + side * (y + side * z);
  }
  const uint32_t h = static_cast<uint32_t>(x) ^ (static_cast<uint32_t>(y) * 2654435761u) ^
                     (static_cast<uint32_t>(z) * 805459861u);
  return static_cast<int64_t>(h & static_cast<uint32_t>(table_size - 1));
}

// The cell of point p on one level: its 8 vertices' rows, their weights, and
// (when `derivative` is set) each weight's derivative along the 3 axes with
// respect to p (zero along a clamped axis).
template <typename T>
struct Cell {
  int64_t row[8];
  T weight[8];
  T derivative[8][3];
};

template <typename T>
FSKIN_HOST_DEVICE void locate(const T* p, int64_t resolution, bool hashed, int64_t table_size, bool derivative,
                              Cell<T>& cell) {
  int64_t base[3];
  T frac[3];
  bool inside[3];
  for (int a = 0; a < 3; ++a) {
    const T c = p[a] < T(0) ? T(0) : (p[a] > T(1) ? T(1) : p[a]);
    inside[a] = p[a] > T(0) && p[a] < T(1);
    const T scaled = c * static_cast<T>(resolution);
    int64_t i = static_cast<int64_t>(scaled);  // floor (scaled >= 0)
    if (i > resolution - 1) i = resolution - 1;
    base[a] = i;
    frac[a] = scaled - static_cast<T>(i);
  }
  for (int corner = 0; corner < 8; ++corner) {
    T w = T(1);
    T one[3];
    for (int a = 0; a < 3; ++a) {
      const bool upper = (corner >> a) & 1;
      one[a] = upper ? frac[a] : T(1) - frac[a];
      w *= one[a];
    }
    cell.weight[corner] = w;
    cell.row[corner] = vertex_row(base[0] + (corner & 1), base[1] + ((corner >> 1) & 1), base[2] + ((corner >> 2) & 1),
                                  resolution, hashed, table_size);
    if (derivative) {
      for (int a = 0; a < 3; ++a) {
        const bool upper = (corner >> a) & 1;
        T d = upper ? static_cast<T>(resolution) : -static_cast<T>(resolution);
        for (int o = 0; o < 3; ++o)
          if (o != a) d *= one[o];
        cell.derivative[corner][a] = inside[a] ? d : T(0);
      }
    }
  }
}

// Forward of point n on level l. The kernels run level by level (all
// points of one level, then the next), so the rows they gather come from one
// level's table at a time: 2^T x F values, not L times as many.
template <typename T>
FSKIN_HOST_DEVICE void encode_point(const EncodingLaunch<T>& a, int64_t n, int64_t l) {
  Cell<T> cell;
  locate(a.positions + 3 * n, a.resolution[l], a.hashed[l], a.table_size, false, cell);
  const T* level = a.table + l * a.table_size * a.features;
  T* out = a.out + n * a.levels * a.features + l * a.features;
  for (int64_t f = 0; f < a.features; ++f) out[f] = T(0);
  for (int c = 0; c < 8; ++c) {
    const T* row = level + cell.row[c] * a.features;
    for (int64_t f = 0; f < a.features; ++f) out[f] += cell.weight[c] * row[f];
  }
}

// d loss / d position of point n: sum over levels, vertices and features.
template <typename T>
FSKIN_HOST_DEVICE void position_gradient(const EncodingLaunch<T>& a, int64_t n) {
  const T* p = a.positions + 3 * n;
  T g[3] = {T(0), T(0), T(0)};
  Cell<T> cell;
  for (int64_t l = 0; l < a.levels; ++l) {
    locate(p, a.resolution[l], a.hashed[l], a.table_size, true, cell);
    const T* level = a.table + l * a.table_size * a.features;
    const T* grad = a.grad_out + n * a.levels * a.features + l * a.features;
    for (int c = 0; c < 8; ++c) {
      const T* row = level + cell.row[c] * a.features;
      T dot = T(0);
      for (int64_t f = 0; f < a.features; ++f) dot += grad[f] * row[f];
      for (int ax = 0; ax < 3; ++ax) g[ax] += dot * cell.derivative[c][ax];
    }
  }
  for (int ax = 0; ax < 3; ++ax) a.grad_positions[3 * n + ax] = g[ax];
}

template <typename T>
void hash_encoding_forward_cpu(const EncodingLaunch<T>& launch);
template <typename T>
void hash_encoding_backward_cpu(const EncodingLaunch<T>& launch);

// Raw device pointers; `stream` is a cudaStream_t. Defined in cuda/ (no LibTorch there).
template <typename T>
void hash_encoding_forward_cuda(const EncodingLaunch<T>& launch, void* stream);
template <typename T>
void hash_encoding_backward_cuda(const EncodingLaunch<T>& launch, void* stream);

}  // namespace fskin::hash_grid
