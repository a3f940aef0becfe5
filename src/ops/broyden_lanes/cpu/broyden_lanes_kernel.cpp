// CPU kernels of broyden_lanes: at::parallel_for over lanes (or points).
#include <ATen/Parallel.h>

#include "ops/broyden_lanes/broyden_lanes_kernel.h"

namespace fskin::broyden {

namespace {
constexpr int64_t kGrain = 1024;
}

template <typename T>
void start_lanes_cpu(const LanesView<T>& v, const T* jacobian) {
  at::parallel_for(0, v.lanes, kGrain, [&](int64_t begin, int64_t end) {
    for (int64_t p = begin; p < end; ++p) start_lane(v, jacobian, p);
  });
}

template <typename T>
void step_lanes_cpu(const LanesView<T>& v, int k, const SearchParams<T>& params) {
  at::parallel_for(0, v.lanes, kGrain, [&](int64_t begin, int64_t end) {
    for (int64_t p = begin; p < end; ++p) step_lane(v, k, params, p);
  });
}

template <typename T>
void update_lanes_cpu(const LanesView<T>& v, const int64_t* stepped, const T* residual, int64_t count, T eps) {
  at::parallel_for(0, count, kGrain, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) update_lane(v, stepped, residual, eps, i);
  });
}

template <typename T>
void rank_starts_cpu(const T* own_weights, int64_t points, int starts, int count, int64_t* out) {
  at::parallel_for(0, points, kGrain, [&](int64_t begin, int64_t end) {
    for (int64_t p = begin; p < end; ++p) rank_row(own_weights, starts, count, out, p);
  });
}

#define FSKIN_INSTANTIATE(T)                                                                          \
  template void start_lanes_cpu<T>(const LanesView<T>&, const T*);                                    \
  template void step_lanes_cpu<T>(const LanesView<T>&, int, const SearchParams<T>&);                  \
  template void update_lanes_cpu<T>(const LanesView<T>&, const int64_t*, const T*, int64_t, T);       \
  template void rank_starts_cpu<T>(const T*, int64_t, int, int, int64_t*);
FSKIN_INSTANTIATE(float)
FSKIN_INSTANTIATE(double)
#undef FSKIN_INSTANTIATE

}  // namespace fskin::broyden
