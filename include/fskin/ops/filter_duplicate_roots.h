#pragma once
// Duplicate removal (Fast-SNARF sec. 4.1): different starts often converge to
// the same root; a valid candidate closer than `distance` to an earlier valid
// candidate of the same point is marked invalid, so the canonical fields are
// evaluated once per distinct root. Dispatches on device (CPU / CUDA). In
// PyTorch's dispatcher as fskin::filter_duplicate_roots; Python:
// torch.ops.fskin.filter_duplicate_roots.
#include <torch/types.h>

namespace fskin {

// x_canonical [B, N, I, 3], valid [B, N, I] bool -> new mask [B, N, I].
torch::Tensor filter_duplicate_roots(const torch::Tensor& x_canonical, const torch::Tensor& valid,
                                     double distance = 1e-4);

}  // namespace fskin
