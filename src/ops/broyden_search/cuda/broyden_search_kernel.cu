// CUDA kernel of broyden_search: one thread per (point, slot) pair, all
// iterations in registers (Fast-SNARF sec. 4.1). Raw pointers only, no
// LibTorch headers, so nvcc builds it even where LibTorch is CPU-only.
#include <cuda_runtime.h>

#include <stdexcept>
#include <string>

#include "ops/broyden_search/broyden_search_kernel.h"

namespace fskin::broyden {
namespace {

template <typename T>
__global__ void broyden_search_kernel(const SearchLaunch<T> a) {
  const int64_t pair = static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (pair >= a.batch * a.points * a.slots) return;
  const int64_t pn = pair / a.slots;
  const int slot = static_cast<int>(pair % a.slots);
  int start = slot;
  if (a.slots < a.starts) {
    T scores[kMaxStarts];
    score_starts(a, pn, scores);
    start = start_of_rank(scores, a.starts, slot);
  }
  search_slots<T, 1>(a, pn, slot, 1, &start);
}

}  // namespace

template <typename T>
void broyden_search_cuda(const SearchLaunch<T>& launch, void* stream) {
  const int64_t pairs = launch.batch * launch.points * launch.slots;
  if (pairs == 0) return;
  constexpr int kThreads = 128;
  const int64_t blocks = (pairs + kThreads - 1) / kThreads;
  broyden_search_kernel<T><<<static_cast<unsigned>(blocks), kThreads, 0, static_cast<cudaStream_t>(stream)>>>(launch);
  const cudaError_t err = cudaGetLastError();
  if (err != cudaSuccess) throw std::runtime_error(std::string("broyden_search CUDA launch: ") + cudaGetErrorString(err));
}

template void broyden_search_cuda<float>(const SearchLaunch<float>&, void*);
template void broyden_search_cuda<double>(const SearchLaunch<double>&, void*);

}  // namespace fskin::broyden
