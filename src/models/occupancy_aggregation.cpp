#include "fskin/models/occupancy_aggregation.h"

#include <torch/torch.h>

#include <limits>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

namespace {
void check_candidates(const torch::Tensor& logits, const torch::Tensor& valid) {
  FSKIN_CHECK(logits.dim() >= 1 && valid.sizes() == logits.sizes() && valid.scalar_type() == torch::kBool,
              "occupancy aggregation: logits {} and bool valid mask {} must have the same shape",
              shape_string(logits.sizes()), shape_string(valid.sizes()));
}

// Clamping the probability (not the logit) to [eps, 1 - eps] keeps the
// gradient finite at p = 0 and p = 1, like the reference's Bernoulli(probs).logits.
torch::Tensor probability_to_logit(const torch::Tensor& p) {
  return torch::logit(p, std::numeric_limits<float>::epsilon());
}
}  // namespace

torch::Tensor soft_max_occupancy(const torch::Tensor& logits, const torch::Tensor& valid, double temperature) {
  check_candidates(logits, valid);
  const auto p = torch::sigmoid(logits);
  // Invalid candidates get -inf before the softmax; a point with none at all
  // would give 0/0, so its weights are replaced by zeros (p* = 0, outside).
  const auto any_valid = valid.any(-1, /*keepdim=*/true);
  const auto scores = (temperature * p).masked_fill(valid.logical_not(), -std::numeric_limits<float>::infinity());
  const auto weights =
      torch::where(any_valid, torch::softmax(scores.masked_fill(any_valid.logical_not(), 0.0), -1),
                   torch::zeros_like(p));
  return probability_to_logit((weights * p).sum(-1));
}

torch::Tensor hard_max_occupancy(const torch::Tensor& logits, const torch::Tensor& valid) {
  check_candidates(logits, valid);
  return logits.masked_fill(valid.logical_not(), -kMaxOccupancyLogit)
      .amax(-1)
      .clamp_min(-kMaxOccupancyLogit);
}

}  // namespace fskin
