#pragma once
// The per-point body of filter_duplicate_roots, shared by its CPU and CUDA kernels.
#include "ops/common/host_device.h"

namespace fskin::kernels {

// Duplicate removal (Fast-SNARF sec. 4.1): a valid root closer than
// sqrt(tolerance_sq) to an earlier valid root is dropped. Only valid roots
// are compared, and each against the kept ones only.
template <typename T>
FSKIN_HOST_DEVICE void drop_duplicate_roots(const T* x, bool* valid, int count, T tolerance_sq) {
  for (int i = 1; i < count; ++i) {
    if (!valid[i]) continue;
    for (int j = 0; j < i; ++j) {
      if (!valid[j]) continue;
      const T d0 = x[3 * i] - x[3 * j], d1 = x[3 * i + 1] - x[3 * j + 1], d2 = x[3 * i + 2] - x[3 * j + 2];
      if (d0 * d0 + d1 * d1 + d2 * d2 < tolerance_sq) {
        valid[i] = false;
        break;
      }
    }
  }
}

}  // namespace fskin::kernels
