// CUDA kernels of broyden_lanes: one thread per lane (or point).
#include "ops/broyden_lanes/broyden_lanes_kernel.h"
#include "ops/common/cuda_launch.cuh"

namespace fskin::broyden {
namespace {

__device__ inline int64_t thread_index() { return static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x; }

template <typename T>
__global__ void start_kernel(const LanesView<T> v, const T* jacobian) {
  const int64_t p = thread_index();
  if (p < v.lanes) start_lane(v, jacobian, p);
}

template <typename T>
__global__ void step_kernel(const LanesView<T> v, int k, const SearchParams<T> params) {
  const int64_t p = thread_index();
  if (p < v.lanes) step_lane(v, k, params, p);
}

template <typename T>
__global__ void update_kernel(const LanesView<T> v, const int64_t* stepped, const T* residual, int64_t count, T eps) {
  const int64_t i = thread_index();
  if (i < count) update_lane(v, stepped, residual, eps, i);
}

template <typename T>
__global__ void rank_kernel(const T* own_weights, int64_t points, int starts, int count, int64_t* out) {
  const int64_t p = thread_index();
  if (p < points) rank_row(own_weights, starts, count, out, p);
}

constexpr int kThreads = 256;

}  // namespace

template <typename T>
void start_lanes_cuda(const LanesView<T>& v, const T* jacobian, void* stream) {
  kernels::launch_1d("broyden_lanes start", v.lanes, kThreads, stream, start_kernel<T>, v, jacobian);
}

template <typename T>
void step_lanes_cuda(const LanesView<T>& v, int k, const SearchParams<T>& params, void* stream) {
  kernels::launch_1d("broyden_lanes step", v.lanes, kThreads, stream, step_kernel<T>, v, k, params);
}

template <typename T>
void update_lanes_cuda(const LanesView<T>& v, const int64_t* stepped, const T* residual, int64_t count, T eps,
                       void* stream) {
  kernels::launch_1d("broyden_lanes update", count, kThreads, stream, update_kernel<T>, v, stepped, residual, count,
                     eps);
}

template <typename T>
void rank_starts_cuda(const T* own_weights, int64_t points, int starts, int count, int64_t* out, void* stream) {
  kernels::launch_1d("rank_starts", points, kThreads, stream, rank_kernel<T>, own_weights, points, starts, count, out);
}

#define FSKIN_INSTANTIATE(T)                                                                                 \
  template void start_lanes_cuda<T>(const LanesView<T>&, const T*, void*);                                   \
  template void step_lanes_cuda<T>(const LanesView<T>&, int, const SearchParams<T>&, void*);                 \
  template void update_lanes_cuda<T>(const LanesView<T>&, const int64_t*, const T*, int64_t, T, void*);      \
  template void rank_starts_cuda<T>(const T*, int64_t, int, int, int64_t*, void*);
FSKIN_INSTANTIATE(float)
FSKIN_INSTANTIATE(double)
#undef FSKIN_INSTANTIATE

}  // namespace fskin::broyden
