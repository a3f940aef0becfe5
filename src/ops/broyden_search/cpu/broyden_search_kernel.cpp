// CPU kernel of broyden_search: at::parallel_for over points; the starts of one
// point advance in lockstep, kLanes at a time, so their independent grid
// fetches overlap (solve_lanes).
#include <ATen/Parallel.h>

#include "ops/broyden_search/broyden_search_kernel.h"

namespace fskin::broyden {

// Starts solved together; measured best on a 2-core Xeon VM (see docs/benchmarks.md).
constexpr int kLanes = 4;

template <typename T>
void broyden_search_cpu(const SearchLaunch<T>& a) {
  const bool automatic = a.slots < a.starts;
  at::parallel_for(0, a.batch * a.points, 256, [&](int64_t begin, int64_t end) {
    T scores[kMaxStarts];
    int starts[kLanes];
    for (int64_t pn = begin; pn < end; ++pn) {
      if (automatic) score_starts(a, pn, scores);
      for (int first = 0; first < a.slots; first += kLanes) {
        const int count = a.slots - first < kLanes ? a.slots - first : kLanes;
        for (int l = 0; l < count; ++l) starts[l] = automatic ? start_of_rank(scores, a.starts, first + l) : first + l;
        search_slots<T, kLanes>(a, pn, first, count, starts);
      }
    }
  });
}

template void broyden_search_cpu<float>(const SearchLaunch<float>&);
template void broyden_search_cpu<double>(const SearchLaunch<double>&);

}  // namespace fskin::broyden
