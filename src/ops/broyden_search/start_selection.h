#pragma once
// The one automatic start rule (StartBones::automatic): per posed point x',
// keep the starts s whose own skinning weight w_s at their own rigid start
// B_s^-1 x' is largest, i.e. whose inverse lands in the region the bone
// drives. The fused search scores starts from the nearest voxel of the weight
// grid (start_score); SNARF's search evaluates w_s with its MLP and ranks the
// same scores (score_from_weight) with the same order (start_of_rank).
#include <cmath>

#include "ops/common/transform_grid.h"

namespace fskin::broyden {

using kernels::GridView;
using kernels::kChannels;

// Upper bound on start bones per point (the local score arrays).
constexpr int kMaxRankedStarts = 128;

// Score of a start from its own weight: lower is better; NaN scores last.
template <typename T>
FSKIN_HOST_DEVICE T score_from_weight(T own_weight) {
  return own_weight == own_weight ? -own_weight : T(INFINITY);
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
  kernels::apply_affine(start_inverse, x_posed, x0);
  if (!kernels::locate(grid, x0, i0, frac)) return T(INFINITY);
  for (int a = 0; a < 3; ++a) i0[a] += frac[a] >= T(0.5);
  const int64_t voxel = (static_cast<int64_t>(i0[2]) * grid.size[1] + i0[1]) * grid.size[0] + i0[0];
  return score_from_weight(weights[voxel * starts + s]);
}

// The start holding rank `rank` when sorting scores ascending (ties by index).
template <typename T>
FSKIN_HOST_DEVICE int start_of_rank(const T* r, int count, int rank) {
  for (int s = 0; s < count; ++s) {
    int smaller = 0;
    for (int t = 0; t < count; ++t) smaller += (r[t] < r[s]) || (r[t] == r[s] && t < s);
    if (smaller == rank) return s;
  }
  return rank;  // unreachable for a strict total order
}

}  // namespace fskin::broyden
