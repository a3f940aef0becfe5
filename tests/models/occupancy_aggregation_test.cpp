#include "fskin/models/occupancy_aggregation.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

namespace fskin {
namespace {

TEST(OccupancyAggregation, SoftMaxFollowsTheValidCandidates) {
  const auto logits = torch::tensor({{2.0f, -3.0f, 9.0f}, {-1.0f, 4.0f, 0.0f}, {5.0f, 5.0f, 5.0f}});
  const auto valid = torch::tensor({{true, true, false}, {true, false, false}, {false, false, false}});
  const auto soft = soft_max_occupancy(logits, valid);
  // One valid candidate: its own logit back.
  EXPECT_NEAR(soft[1].item<float>(), -1.0f, 1e-4);
  // Two: between them, pulled towards the more occupied one (temperature 5).
  const double p0 = 1 / (1 + std::exp(-2.0)), p1 = 1 / (1 + std::exp(3.0));
  const double a0 = std::exp(5 * p0) / (std::exp(5 * p0) + std::exp(5 * p1));
  const double p = a0 * p0 + (1 - a0) * p1;
  EXPECT_NEAR(soft[0].item<float>(), std::log(p / (1 - p)), 1e-4);
  // None valid: outside, at the clamp.
  EXPECT_NEAR(soft[2].item<float>(), -kMaxOccupancyLogit, 0.01);
}

TEST(OccupancyAggregation, SoftMaxGradientIsFiniteEverywhere) {
  auto logits = torch::tensor({{40.0f, -40.0f}, {3.0f, 1.0f}}).requires_grad_(true);
  const auto valid = torch::tensor({{false, false}, {true, true}});
  soft_max_occupancy(logits, valid).sum().backward();
  EXPECT_TRUE(torch::isfinite(logits.grad()).all().item<bool>());
  EXPECT_EQ(logits.grad()[0].abs().sum().item<float>(), 0.0f);
  EXPECT_GT(logits.grad()[1].abs().min().item<float>(), 0.0f);
}

TEST(OccupancyAggregation, HardMaxIgnoresInvalidCandidates) {
  const auto logits = torch::tensor({{2.0f, -3.0f, 9.0f}, {-20.0f, -30.0f, 1.0f}});
  const auto valid = torch::tensor({{true, true, false}, {true, true, false}});
  const auto hard = hard_max_occupancy(logits, valid);
  EXPECT_FLOAT_EQ(hard[0].item<float>(), 2.0f);
  EXPECT_NEAR(hard[1].item<float>(), -kMaxOccupancyLogit, 1e-5);
  EXPECT_THROW(hard_max_occupancy(logits, valid.slice(1, 0, 2)), std::exception);
}

}  // namespace
}  // namespace fskin
