#pragma once
// Device kernels of broyden_search, one per folder (cpu/, cuda/).
#include "ops/broyden_search/broyden_search_launch.h"

namespace fskin::broyden {

template <typename T>
void broyden_search_cpu(const SearchLaunch<T>& launch);

// Raw device pointers; `stream` is a cudaStream_t. Defined in cuda/ (no LibTorch there).
template <typename T>
void broyden_search_cuda(const SearchLaunch<T>& launch, void* stream);

}  // namespace fskin::broyden
