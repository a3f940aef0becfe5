// CUDA kernel of the ray compositing: one thread per ray. Raw pointers only,
// no LibTorch headers, so nvcc builds it even where LibTorch is CPU-only.
#include "ops/common/cuda_launch.cuh"
#include "ops/ray_compositing/ray_compositing_kernel.h"

namespace fskin::ray_compositing {
namespace {

template <typename T>
__global__ void composite_kernel(const CompositeLaunch<T> a, bool backward) {
  const int64_t r = static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (r >= a.rays) return;
  if (backward) {
    composite_ray_backward(a, r);
  } else {
    composite_ray(a, r);
  }
}

}  // namespace

template <typename T>
void composite_rays_cuda(const CompositeLaunch<T>& launch, bool backward, void* stream) {
  kernels::launch_1d(backward ? "composite_rays backward" : "composite_rays", launch.rays, 128, stream,
                     composite_kernel<T>, launch, backward);
}

template void composite_rays_cuda<float>(const CompositeLaunch<float>&, bool, void*);
template void composite_rays_cuda<double>(const CompositeLaunch<double>&, bool, void*);

}  // namespace fskin::ray_compositing
