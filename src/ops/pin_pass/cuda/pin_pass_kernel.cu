// CUDA kernel of the fused PIN pass: one thread per point, the same
// pin_block code as the CPU kernel on a float.
#include <cuda_runtime.h>

#include <stdexcept>
#include <string>

#include "ops/pin_pass/pin_pass_kernel.h"

namespace fskin::pin_pass {
namespace {

__global__ void pin_pass_kernel(const PinPassLaunch a) {
  const int64_t i = static_cast<int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= a.batch * a.count) return;
  const int64_t b = i / a.count;
  float x[3] = {a.points[3 * i], a.points[3 * i + 1], a.points[3 * i + 2]};
  Scratch<float> scratch;
  pin_block(a.shape, a.params + b * a.frame_stride, a.inverse, x, scratch);
  for (int c = 0; c < 3; ++c) a.points[3 * i + c] = x[c];
}

}  // namespace

void pin_pass_cuda(const PinPassLaunch& a, void* stream) {
  constexpr int kThreads = 128;
  const int64_t total = a.batch * a.count;
  const int64_t blocks = (total + kThreads - 1) / kThreads;
  if (blocks == 0) return;
  pin_pass_kernel<<<static_cast<unsigned>(blocks), kThreads, 0, static_cast<cudaStream_t>(stream)>>>(a);
  const cudaError_t err = cudaGetLastError();
  if (err != cudaSuccess) throw std::runtime_error(std::string("fused PIN pass CUDA launch: ") + cudaGetErrorString(err));
}

}  // namespace fskin::pin_pass
