// CUDA kernel of the fused PIN pass: one thread per point, the same
// pin_block code as the CPU kernel on a float.
#include "ops/common/cuda_launch.cuh"
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
  kernels::launch_1d("fused PIN pass", a.batch * a.count, 128, stream, pin_pass_kernel, a);
}

}  // namespace fskin::pin_pass
