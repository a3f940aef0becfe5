// CUDA kernel of filter_duplicate_roots: one thread per point (I is small).
#include <cuda_runtime.h>

#include <stdexcept>
#include <string>

#include "ops/broyden_search/broyden_core.h"
#include "ops/filter_duplicate_roots/filter_duplicate_roots_kernel.h"

namespace fskin::broyden {
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
  constexpr int kThreads = 256;
  const int64_t blocks = (a.points + kThreads - 1) / kThreads;
  filter_kernel<T><<<static_cast<unsigned>(blocks), kThreads, 0, static_cast<cudaStream_t>(stream)>>>(a);
  const cudaError_t err = cudaGetLastError();
  if (err != cudaSuccess) throw std::runtime_error(std::string("filter_duplicate_roots CUDA launch: ") + cudaGetErrorString(err));
}

template void filter_duplicate_roots_cuda<float>(const FilterLaunch<float>&, void*);
template void filter_duplicate_roots_cuda<double>(const FilterLaunch<double>&, void*);

}  // namespace fskin::broyden
