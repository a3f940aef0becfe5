#pragma once
// Raw-pointer arguments of one broyden_search launch and the per-(point, start)
// body shared by the CPU and CUDA kernels. Torch-free so nvcc compiles it.
#include "ops/broyden_search/broyden_core.h"
#include "ops/broyden_search/start_selection.h"

namespace fskin::broyden {

// Upper bound on start bones per point (local arrays of the automatic selection).
constexpr int kMaxStarts = kMaxRankedStarts;

template <typename T>
struct SearchLaunch {
  GridView<T> grid;              // data of frame 0; frame b starts at data + b * grid_frame_stride
  int64_t grid_frame_stride;
  const T* x_posed;              // [B, N, 3]
  const T* start_inverses;       // [B, S, 12] row-major 3x4
  const T* start_weights;        // [D, H, W, S] weights of the start bones (automatic selection) or nullptr
  int64_t batch, points;
  int starts, slots;             // S candidate starts, I kept per point (I <= S)
  SearchParams<T> params;
  T* x_out;                      // [B, N, I, 3]
  bool* valid_out;               // [B, N, I]
  uint8_t* iterations_out;       // [B, N, I]
  int64_t* start_index_out;      // [B, N, I]
  T* inverse_jacobian_out;       // [B, N, I, 9] or nullptr
};

template <typename T>
FSKIN_HOST_DEVICE GridView<T> frame_grid(const SearchLaunch<T>& a, int64_t b) {
  GridView<T> g = a.grid;
  g.data += b * a.grid_frame_stride;
  return g;
}

// Scores of all S starts of point `pn` (= b * N + n) into r[0..S), lower is better.
template <typename T>
FSKIN_HOST_DEVICE void score_starts(const SearchLaunch<T>& a, int64_t pn, T* r) {
  const int64_t b = pn / a.points;
  const T* xp = a.x_posed + 3 * pn;
  for (int s = 0; s < a.starts; ++s) {
    r[s] = start_score(a.grid, a.start_weights, a.starts, s, xp, a.start_inverses + (b * a.starts + s) * kChannels);
  }
}

// Search of `count` <= L consecutive slots of point `pn` (= b * N + n), slot
// first_slot + l starting from start bone starts[l].
template <typename T, int L>
FSKIN_HOST_DEVICE void search_slots(const SearchLaunch<T>& a, int64_t pn, int first_slot, int count,
                                    const int* starts) {
  const int64_t b = pn / a.points;
  const GridView<T> g = frame_grid(a, b);
  const T* xp = a.x_posed + 3 * pn;
  T x[L][3], jinv[L][9];
  SolveResult res[L];
  for (int l = 0; l < count; ++l) kernels::apply_affine(a.start_inverses + (b * a.starts + starts[l]) * kChannels, xp, x[l]);
  solve_lanes<T, L>(g, xp, x, jinv, res, count, a.params);
  for (int l = 0; l < count; ++l) {
    const int64_t o = pn * a.slots + first_slot + l;
    for (int k = 0; k < 3; ++k) a.x_out[3 * o + k] = x[l][k];
    a.valid_out[o] = res[l].valid;
    a.iterations_out[o] = static_cast<uint8_t>(res[l].iterations);
    a.start_index_out[o] = starts[l];
    if (a.inverse_jacobian_out) {
      for (int k = 0; k < 9; ++k) a.inverse_jacobian_out[9 * o + k] = jinv[l][k];
    }
  }
}

}  // namespace fskin::broyden
