#pragma once
// Raw-pointer arguments of one grid_forward_skinning launch, its per-point
// body and the device kernels (cpu/, cuda/). Torch-free so nvcc compiles it.
#include "ops/common/transform_grid.h"

namespace fskin::grid_skinning {

template <typename T>
struct SkinningLaunch {
  kernels::GridView<T> grid;  // data of frame 0; frame b starts at data + b * grid_frame_stride
  int64_t grid_frame_stride;
  const T* x;                 // [B, N, 3]
  int64_t batch, points;
  T* out;                     // [B, N, 3]
};

// x' = T(x) x for point pn (= b * N + n): eq. 14 then the affine map.
template <typename T>
FSKIN_HOST_DEVICE void skin_point(const SkinningLaunch<T>& a, int64_t pn) {
  kernels::GridView<T> g = a.grid;
  g.data += (pn / a.points) * a.grid_frame_stride;
  T transform[kernels::kChannels];
  kernels::trilinear_fetch(g, a.x + 3 * pn, transform);
  kernels::apply_affine(transform, a.x + 3 * pn, a.out + 3 * pn);
}

template <typename T>
void grid_forward_skinning_cpu(const SkinningLaunch<T>& launch);

// Raw device pointers; `stream` is a cudaStream_t. Defined in cuda/ (no LibTorch there).
template <typename T>
void grid_forward_skinning_cuda(const SkinningLaunch<T>& launch, void* stream);

}  // namespace fskin::grid_skinning
