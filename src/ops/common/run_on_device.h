#pragma once
// The device dispatch every fused op shares: its CPU kernel for CPU tensors,
// its CUDA kernel on the tensor's device and current stream, or an error that
// names the op when the tensor is elsewhere or fskin was built without CUDA.
#include <torch/types.h>

#include "fskin/core/error.h"

#ifdef FSKIN_WITH_CUDA
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>
#endif

namespace fskin {

// cpu(): runs the CPU kernel; cuda(stream): the CUDA kernel on `stream` (a
// cudaStream_t as void*). Without FSKIN_WITH_CUDA, cuda is never called, so
// its kernel need not be linked.
template <typename Cpu, typename Cuda>
void run_on_device(const torch::Tensor& tensor, const char* op, Cpu&& cpu, Cuda&& cuda) {
  if (tensor.is_cpu()) {
    cpu();
    return;
  }
#ifdef FSKIN_WITH_CUDA
  FSKIN_CHECK(tensor.is_cuda(), "{}: unsupported device {}", op, tensor.device().str());
  const c10::cuda::CUDAGuard guard(tensor.device());
  cuda(static_cast<void*>(c10::cuda::getCurrentCUDAStream().stream()));
#else
  (void)cuda;
  fail("{}: tensors on {} but fskin was built without CUDA kernels", op, tensor.device().str());
#endif
}

}  // namespace fskin
