#pragma once
// Device kernels of the fused PIN pass (torch-free arguments).
#include <cstdint>

#include "ops/pin_pass/pin_pass_core.h"

namespace fskin::pin_pass {

struct PinPassLaunch {
  PinShape shape;
  const float* params;   // [B, frame_stride] packed per frame (pin_pass_core.h)
  int64_t frame_stride;
  float* points;         // [B, N, 3], transformed in place
  int64_t batch, count;  // B, N
  bool inverse;
};

void pin_pass_cpu(const PinPassLaunch& launch);
void pin_pass_cuda(const PinPassLaunch& launch, void* stream);

}  // namespace fskin::pin_pass
