// CUDA kernels of the hash encoding: one thread per (level, point), level
// major, for the forward and the table gradient (scattered with atomicAdd:
// float and, from sm_60, double), one per point for the position gradient.
// Raw pointers only, no LibTorch headers, so nvcc builds it even where
// LibTorch is CPU-only.
#include "ops/common/cuda_launch.cuh"
#include "ops/hash_encoding/hash_encoding_kernel.h"

namespace fskin::hash_grid {
namespace {

// Level-major threads (i = l * N + n): neighbouring threads read one level's table.
template <typename T>
__global__ void forward_kernel(const EncodingLaunch<T> a) {
  const int64_t i = static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < a.points * a.levels) encode_point(a, i % a.points, i / a.points);
}

template <typename T>
__global__ void table_gradient_kernel(const EncodingLaunch<T> a) {
  const int64_t i = static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= a.points * a.levels) return;
  const int64_t n = i % a.points, l = i / a.points;  // level-major, as the forward
  Cell<T> cell;
  locate(a.positions + 3 * n, a.resolution[l], a.hashed[l], a.table_size, false, cell);
  const T* grad = a.grad_out + n * a.levels * a.features + l * a.features;
  T* level = a.grad_table + l * a.table_size * a.features;
  for (int c = 0; c < 8; ++c) {
    T* row = level + cell.row[c] * a.features;
    for (int64_t f = 0; f < a.features; ++f) atomicAdd(row + f, cell.weight[c] * grad[f]);
  }
}

template <typename T>
__global__ void position_gradient_kernel(const EncodingLaunch<T> a) {
  const int64_t n = static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (n < a.points) position_gradient(a, n);
}

}  // namespace

template <typename T>
void hash_encoding_forward_cuda(const EncodingLaunch<T>& launch, void* stream) {
  kernels::launch_1d("hash_encoding", launch.points * launch.levels, 256, stream, forward_kernel<T>, launch);
}

template <typename T>
void hash_encoding_backward_cuda(const EncodingLaunch<T>& launch, void* stream) {
  if (launch.grad_table)
    kernels::launch_1d("hash_encoding backward", launch.points * launch.levels, 256, stream, table_gradient_kernel<T>,
                       launch);
  if (launch.grad_positions)
    kernels::launch_1d("hash_encoding backward", launch.points, 256, stream, position_gradient_kernel<T>, launch);
}

template void hash_encoding_forward_cuda<float>(const EncodingLaunch<float>&, void*);
template void hash_encoding_forward_cuda<double>(const EncodingLaunch<double>&, void*);
template void hash_encoding_backward_cuda<float>(const EncodingLaunch<float>&, void*);
template void hash_encoding_backward_cuda<double>(const EncodingLaunch<double>&, void*);

}  // namespace fskin::hash_grid
