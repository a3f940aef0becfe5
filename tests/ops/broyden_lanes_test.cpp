#include "fskin/ops/broyden_lanes.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/geometry/voxel_box.h"
#include "fskin/ops/broyden_search.h"
#include "test_util.h"

namespace fskin {
namespace {

// A transform grid that varies smoothly over a box around the origin: every
// voxel holds the identity plus a small random 3x4 perturbation.
struct BentField {
  VoxelBox box;
  torch::Tensor grid;  // [D, H, W, 12]
  BentField() {
    box.shape = GridShape{6, 7, 8};
    torch::manual_seed(3);
    const auto identity = torch::eye(4, torch::kFloat64).narrow(0, 0, 3).reshape({12});
    grid = (identity + 0.08 * torch::randn({6, 7, 8, 12}, torch::kFloat64)).contiguous();
  }
  // d(x) = T(x) x at x [M, 3], with T trilinear in the grid (LibTorch, as SNARF's MLP path would).
  torch::Tensor deform(const torch::Tensor& x) const {
    const auto t = sample_voxels(grid, box, x).reshape({-1, 3, 4});
    return torch::matmul(t.narrow(2, 0, 3), x.unsqueeze(-1)).squeeze(-1) + t.select(2, 3);
  }
  torch::Tensor blended_rotation(const torch::Tensor& x) const {
    return sample_voxels(grid, box, x).reshape({-1, 3, 4}).narrow(2, 0, 3);
  }
};

// SNARF's search (residuals evaluated outside, between steps) and the fused
// Fast-SNARF kernel run the same solver: on the same field, from the same
// starts and initial Jacobians, they take the same steps to the same roots.
TEST(BroydenLanes, TakeTheSameStepsAsTheFusedSearch) {
  const BentField field;
  const auto x_true = (torch::rand({300, 3}, torch::kFloat64) - 0.5) * 0.8;
  const auto x_posed = field.deform(x_true);
  BroydenSearchOptions o;
  o.max_iterations = 20;
  o.converge_sq = 1e-20;
  o.diverge_sq = 1.0;
  const auto identity_start = torch::eye(4, torch::kFloat64).reshape({1, 1, 4, 4});
  const auto fused = broyden_search(field.grid.unsqueeze(0), field.box, x_posed.unsqueeze(0), identity_start, o);

  // The fused kernel starts from the inverse of the blended 3x3 at x0 = x'.
  auto lanes = start_broyden_lanes(x_posed, field.deform(x_posed) - x_posed, field.blended_rotation(x_posed));
  int steps = 0;
  for (int k = 0;; ++k) {
    const auto stepped = step_broyden_lanes(lanes, k, o);
    if (stepped.numel() == 0) break;
    ++steps;
    const auto x = lanes.x.index_select(0, stepped);
    update_broyden_lanes(lanes, stepped, field.deform(x) - x_posed.index_select(0, stepped), o);
  }
  const auto converged = lanes.state == kLaneConverged;
  EXPECT_GT(steps, 2);  // a real iteration, not one Newton step
  EXPECT_GT(converged.to(torch::kFloat64).mean().item<double>(), 0.95);
  EXPECT_TRUE(torch::equal(converged, fused.valid.reshape({-1})));
  EXPECT_TRUE(torch::equal(lanes.iterations, fused.iterations.reshape({-1})));
  const auto fused_x = fused.x_canonical.reshape({-1, 3});
  EXPECT_LT((lanes.x - fused_x).abs().max().item<double>(), 1e-9);
  // Roots of d(x) = x' (the bent field has a second root for a few points).
  const auto residual = field.deform(lanes.x) - x_posed;
  EXPECT_LT(residual.index({converged}).abs().max().item<double>(), 1e-9);
}

TEST(BroydenLanes, FinalStepAndDenominatorAreNamedOptions) {
  // A linear map: the converged lane stops where it is without the final
  // step, and moves to the exact root with it.
  const auto a = torch::tensor({{1.2, 0.1, 0.0}, {0.0, 0.9, 0.2}, {0.1, 0.0, 1.1}}, torch::kFloat64);
  const auto root = torch::tensor({{0.3, -0.2, 0.1}}, torch::kFloat64);
  const auto target = torch::matmul(root, a.t());
  const auto x0 = root + 1e-7;  // |r| ~ 2e-7: converged at iteration 0 for converge_sq = 1e-12
  BroydenSearchOptions o;
  o.converge_sq = 1e-12;
  for (const bool final_step : {false, true}) {
    o.final_step = final_step;
    auto lanes = start_broyden_lanes(x0, torch::matmul(x0, a.t()) - target, a.unsqueeze(0));
    EXPECT_EQ(step_broyden_lanes(lanes, 0, o).numel(), 0);
    EXPECT_EQ(lanes.state[0].item<int>(), kLaneConverged);
    const double error = (lanes.x - root).abs().max().item<double>();
    if (final_step) {
      EXPECT_LT(error, 1e-15);
    } else {
      EXPECT_NEAR(error, 1e-7, 1e-12);
    }
  }
}

TEST(BroydenLanes, DivergedAndExhaustedLanesFail) {
  // A residual above diverge_sq fails the lane; with no iterations allowed an
  // unconverged lane fails at once.
  const auto x0 = torch::tensor({{0.0, 0.0, 0.0}}, torch::kFloat64);
  BroydenSearchOptions o;
  o.diverge_sq = 1.0;
  auto lanes = start_broyden_lanes(x0, torch::tensor({{5.0, 0.0, 0.0}}, torch::kFloat64),
                                   torch::eye(3, torch::kFloat64).unsqueeze(0));
  EXPECT_EQ(step_broyden_lanes(lanes, 0, o).numel(), 0);
  EXPECT_EQ(lanes.state[0].item<int>(), kLaneFailed);
  o.diverge_sq = 100;
  o.max_iterations = 0;
  lanes = start_broyden_lanes(x0, torch::tensor({{1.0, 0.0, 0.0}}, torch::kFloat64),
                              torch::eye(3, torch::kFloat64).unsqueeze(0));
  EXPECT_EQ(step_broyden_lanes(lanes, 0, o).numel(), 0);
  EXPECT_EQ(lanes.state[0].item<int>(), kLaneFailed);
  EXPECT_EQ(lanes.iterations[0].item<int>(), 0);
}

TEST(BroydenLanes, SingularJacobianStartsFromTheIdentity) {
  const auto x0 = torch::zeros({1, 3}, torch::kFloat64);
  auto lanes = start_broyden_lanes(x0, torch::zeros({1, 3}, torch::kFloat64), torch::zeros({1, 3, 3}, torch::kFloat64));
  EXPECT_TRUE(torch::equal(lanes.inverse_jacobian[0], torch::eye(3, torch::kFloat64)));
}

TEST(RankStarts, LargestOwnWeightFirstTiesByIndexNanLast) {
  const double nan = std::nan("");
  const auto w = torch::tensor({{0.1, 0.5, 0.2, 0.5}, {nan, 0.0, 0.3, 0.3}}, torch::kFloat64);
  const auto order = rank_starts(w, 3);
  EXPECT_TRUE(torch::equal(order, torch::tensor({{1, 3, 2}, {2, 3, 1}}, torch::kInt64))) << order;
}

TEST(BroydenLanes, RejectsBadInput) {
  const auto x = torch::zeros({4, 3});
  testing::expect_error([&] { start_broyden_lanes(x, torch::zeros({3, 3}), torch::zeros({4, 3, 3})); },
                        {"start_broyden_lanes", "residual"});
  testing::expect_error([&] { start_broyden_lanes(torch::zeros({4, 3}, torch::kInt32), x, torch::zeros({4, 3, 3})); },
                        {"float32 or float64"});
  auto lanes = start_broyden_lanes(x, x, torch::eye(3).expand({4, 3, 3}));
  BroydenSearchOptions o;
  o.diverge_sq = o.converge_sq / 2;
  testing::expect_error([&] { step_broyden_lanes(lanes, 0, o); }, {"thresholds"});
  testing::expect_error([&] { update_broyden_lanes(lanes, torch::zeros({2}, torch::kInt64), torch::zeros({3, 3}), {}); },
                        {"update_broyden_lanes: residual"});
  testing::expect_error([&] { rank_starts(torch::zeros({2, 3}), 4); }, {"rank_starts", "count"});
}

}  // namespace
}  // namespace fskin
