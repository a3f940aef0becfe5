// CUDA kernel of filter_duplicate_roots: one thread per point (I is small).
#include "ops/common/cuda_launch.cuh"
#include "ops/filter_duplicate_roots/filter_duplicate_roots_core.h"
#include "ops/filter_duplicate_roots/filter_duplicate_roots_kernel.h"

namespace fskin::kernels {
namespace {

template <typename T>
__global__ void filter_kernel(const FilterLaunch<T> a) {
  const int64_t p = static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (p >= a.points) return;
  drop_duplicate_roots(a.x + p * a.slots * 3, a.valid + p * a.slots, a.slots, a.tolerance_sq);
}

}  // namespace

template <typename T>
void filter_duplicate_roots_cuda(const FilterLaunch<T>& a, void* stream) {
  launch_1d("filter_duplicate_roots", a.points, 256, stream, filter_kernel<T>, a);
}

template void filter_duplicate_roots_cuda<float>(const FilterLaunch<float>&, void*);
template void filter_duplicate_roots_cuda<double>(const FilterLaunch<double>&, void*);

}  // namespace fskin::kernels
