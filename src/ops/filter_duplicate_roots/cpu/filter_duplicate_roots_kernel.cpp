#include <ATen/Parallel.h>

#include "ops/filter_duplicate_roots/filter_duplicate_roots_core.h"
#include "ops/filter_duplicate_roots/filter_duplicate_roots_kernel.h"

namespace fskin::kernels {

template <typename T>
void filter_duplicate_roots_cpu(const FilterLaunch<T>& a) {
  at::parallel_for(0, a.points, 4096, [&](int64_t begin, int64_t end) {
    for (int64_t p = begin; p < end; ++p) {
      drop_duplicate_roots(a.x + p * a.slots * 3, a.valid + p * a.slots, a.slots, a.tolerance_sq);
    }
  });
}

template void filter_duplicate_roots_cpu<float>(const FilterLaunch<float>&);
template void filter_duplicate_roots_cpu<double>(const FilterLaunch<double>&);

}  // namespace fskin::kernels
