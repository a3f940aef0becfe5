// CUDA kernel of grid_forward_skinning: one thread per point. Raw pointers
// only, no LibTorch headers, so nvcc builds it even where LibTorch is CPU-only.
#include <cuda_runtime.h>

#include <stdexcept>
#include <string>

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
  const int64_t points = launch.batch * launch.points;
  if (points == 0) return;
  constexpr int kThreads = 256;
  const int64_t blocks = (points + kThreads - 1) / kThreads;
  grid_forward_skinning_kernel<T>
      <<<static_cast<unsigned>(blocks), kThreads, 0, static_cast<cudaStream_t>(stream)>>>(launch);
  const cudaError_t err = cudaGetLastError();
  if (err != cudaSuccess) {
    throw std::runtime_error(std::string("grid_forward_skinning CUDA launch: ") + cudaGetErrorString(err));
  }
}

template void grid_forward_skinning_cuda<float>(const SkinningLaunch<float>&, void*);
template void grid_forward_skinning_cuda<double>(const SkinningLaunch<double>&, void*);

}  // namespace fskin::grid_skinning
