// CUDA kernel of broyden_search: one thread per (point, slot) pair, all
// iterations in registers (Fast-SNARF sec. 4.1). Raw pointers only, no
// LibTorch headers, so nvcc builds it even where LibTorch is CPU-only.
#include "ops/broyden_search/broyden_search_kernel.h"
#include "ops/common/cuda_launch.cuh"

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
  kernels::launch_1d("broyden_search", launch.batch * launch.points * launch.slots, 128, stream,
                     broyden_search_kernel<T>, launch);
}

template void broyden_search_cuda<float>(const SearchLaunch<float>&, void*);
template void broyden_search_cuda<double>(const SearchLaunch<double>&, void*);

}  // namespace fskin::broyden
