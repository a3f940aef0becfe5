#pragma once
// Device kernels of filter_duplicate_roots (torch-free arguments).
#include <cstdint>

namespace fskin::kernels {

template <typename T>
struct FilterLaunch {
  const T* x;      // [P, I, 3]
  bool* valid;     // [P, I], updated in place
  int64_t points;  // P
  int slots;       // I
  T tolerance_sq;
};

template <typename T>
void filter_duplicate_roots_cpu(const FilterLaunch<T>& launch);
template <typename T>
void filter_duplicate_roots_cuda(const FilterLaunch<T>& launch, void* stream);

}  // namespace fskin::kernels
