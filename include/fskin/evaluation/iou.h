#pragma once
// Volumetric IoU, the papers' accuracy measure (SNARF sec. 4.1).
#include <torch/types.h>

namespace fskin {

// Intersection over union of two bool masks (1 when both are empty).
double intersection_over_union(const torch::Tensor& predicted, const torch::Tensor& truth);

}  // namespace fskin
