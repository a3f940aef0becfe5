#pragma once
// The launch of every fskin CUDA kernel: a 1-D grid of `count` threads on the
// caller's stream, then the launch checked, a failure thrown as fskin::Error
// naming the op. No device synchronisation: a kernel's own errors surface at
// the next synchronising call, as with LibTorch's kernels.
#include <cuda_runtime.h>

#include <cstdint>
#include <string>

#include "fskin/core/error.h"

namespace fskin::kernels {

template <typename Kernel, typename... Args>
void launch_1d(const char* op, int64_t count, int threads_per_block, void* stream, Kernel kernel,
               const Args&... args) {
  if (count <= 0) return;
  const int64_t blocks = (count + threads_per_block - 1) / threads_per_block;
  kernel<<<static_cast<unsigned>(blocks), threads_per_block, 0, static_cast<cudaStream_t>(stream)>>>(args...);
  const cudaError_t err = cudaGetLastError();
  if (err != cudaSuccess) throw Error(std::string(op) + ": CUDA kernel launch failed: " + cudaGetErrorString(err));
}

}  // namespace fskin::kernels
