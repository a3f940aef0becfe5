// CUDA kernel of grid_forward_skinning: one thread per point. Raw pointers
// only, no LibTorch headers, so nvcc builds it even where LibTorch is CPU-only.
#include "ops/common/cuda_launch.cuh"
#include "ops/grid_forward_skinning/grid_forward_skinning_kernel.h"

namespace fskin::grid_skinning {
namespace {

template <typename T>
__global__ void grid_forward_skinning_kernel(const SkinningLaunch<T> a) {
  const int64_t pn = static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (pn < a.batch * a.points) skin_point(a, pn);
}

}  // namespace

template <typename T>
void grid_forward_skinning_cuda(const SkinningLaunch<T>& launch, void* stream) {
  kernels::launch_1d("grid_forward_skinning", launch.batch * launch.points, 256, stream,
                     grid_forward_skinning_kernel<T>, launch);
}

template void grid_forward_skinning_cuda<float>(const SkinningLaunch<float>&, void*);
template void grid_forward_skinning_cuda<double>(const SkinningLaunch<double>&, void*);

}  // namespace fskin::grid_skinning
