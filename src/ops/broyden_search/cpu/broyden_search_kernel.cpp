// CPU kernel of broyden_search: at::parallel_for over points; the starts of one
// point run back to back so its posed point and grid neighbourhood stay in cache.
#include <ATen/Parallel.h>

#include "ops/broyden_search/broyden_search_kernel.h"

namespace fskin::broyden {

template <typename T>
void broyden_search_cpu(const SearchLaunch<T>& a) {
  const bool automatic = a.slots < a.starts;
  at::parallel_for(0, a.batch * a.points, 256, [&](int64_t begin, int64_t end) {
    T residuals[kMaxStarts];
    for (int64_t pn = begin; pn < end; ++pn) {
      if (automatic) rank_inputs(a, pn, residuals);
      for (int slot = 0; slot < a.slots; ++slot) {
        search_pair(a, pn, slot, automatic ? start_of_rank(residuals, a.starts, slot) : slot);
      }
    }
  });
}

template void broyden_search_cpu<float>(const SearchLaunch<float>&);
template void broyden_search_cpu<double>(const SearchLaunch<double>&);

}  // namespace fskin::broyden
