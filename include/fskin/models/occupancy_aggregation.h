#pragma once
// Occupancy of a posed point from the occupancy of its canonical candidates
// (SNARF eq. 9: the union, a max over candidates). Training uses a soft max so
// every valid candidate receives gradient; evaluation the hard max.
#include <torch/types.h>

namespace fskin {

// Logit of float32's smallest representable probability gap:
// log((1 - eps) / eps) with eps = 1.19e-7, the clamp of the reference code.
constexpr double kMaxOccupancyLogit = 15.94;

// Training aggregation: p = sigmoid(logit), a = softmax over valid candidates
// of temperature * p, p* = sum a p, returned as a logit clamped to
// +-kMaxOccupancyLogit. Points without a valid candidate get p* = 0.
// logits [..., I], valid [..., I] bool -> [...].
torch::Tensor soft_max_occupancy(const torch::Tensor& logits, const torch::Tensor& valid,
                                 double temperature = 5.0);

// Evaluation aggregation: max of the valid logits; -kMaxOccupancyLogit (outside)
// where no candidate is valid.
torch::Tensor hard_max_occupancy(const torch::Tensor& logits, const torch::Tensor& valid);

}  // namespace fskin
