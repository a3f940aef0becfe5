#include "fskin/invertible/operation_map.h"

#include <gtest/gtest.h>

#include "fskin/core/error.h"
#include "invertible/invertible_test_util.h"
#include "test_util.h"

namespace fskin {
namespace {

OperationMapOptions small_options(int64_t output_dim) {
  OperationMapOptions o;
  o.embedding_dim = 10;
  o.hidden_dim = 8;
  o.hidden_layers = 3;
  o.output_dim = output_dim;
  return o;
}

TEST(OperationMap, StartsAtZero) {
  torch::manual_seed(0);
  OperationMap map(small_options(2));
  const auto out = map->forward(torch::randn({2, 5, 10}), torch::randn({2, 10}));
  EXPECT_EQ(out.sizes(), (std::vector<int64_t>{2, 5, 2}));
  EXPECT_TRUE(torch::equal(out, torch::zeros_like(out)));  // Appendix C.1
}

TEST(OperationMap, IsZeroAtZeroConditioningForAnyParameters) {
  torch::manual_seed(1);
  OperationMap map(small_options(1));
  testing::randomize_parameters(*map);
  const auto zero = map->forward(torch::zeros({2, 5, 10}), torch::zeros({2, 10}));
  // M(0) - M(0), up to rounding: the per-point and the reference evaluation may
  // take different BLAS paths.
  EXPECT_LT(zero.abs().max().item<double>(), 1e-6);
  const auto nonzero = map->forward(torch::randn({2, 5, 10}), torch::randn({2, 10}));
  EXPECT_GT(nonzero.abs().min().item<double>(), 0.0);
}

TEST(OperationMap, IsAnMlpOnTheConcatenatedConditioning) {
  // Eq. 9-11: M(c) with c = [z_s * z_p, z_p]; the split first layer must equal a
  // Linear on the concatenation (minus the same MLP at c = 0: the centring).
  torch::manual_seed(2);
  OperationMap map(small_options(2));
  map->to(torch::kFloat64);
  testing::randomize_parameters(*map);
  auto p = map->named_parameters();
  const auto w1 = torch::cat({p["first_space_pose.weight"], p["first_pose.weight"]}, 1);
  auto mlp = [&](const torch::Tensor& c) {
    auto h = torch::softplus(torch::linear(c, w1, p["first_space_pose.bias"]), 100.0, 20.0);
    for (int64_t l = 1; l < 3; ++l) {
      const auto name = "hidden" + std::to_string(l);
      h = torch::softplus(torch::linear(h, p[name + ".weight"], p[name + ".bias"]), 100.0, 20.0);
    }
    return torch::linear(h, p["last.weight"]);
  };
  const auto space = torch::randn({2, 5, 10}, torch::kFloat64);
  const auto pose = torch::randn({2, 10}, torch::kFloat64);
  const auto c = torch::cat({space * pose.unsqueeze(1), pose.unsqueeze(1).expand({2, 5, 10})}, -1);
  const auto expected = mlp(c) - mlp(torch::zeros({20}, torch::kFloat64));
  EXPECT_TRUE(torch::allclose(map->forward(space, pose), expected, 1e-12, 1e-12));

  // A linear projection z_s = f P^T + p folds into the first layer: the same
  // function as projecting first, with the same gradients.
  const auto features = torch::randn({2, 5, 7}, torch::kFloat64).requires_grad_();
  const SpaceProjection projection{torch::randn({10, 7}, torch::kFloat64).requires_grad_(),
                                   torch::randn({10}, torch::kFloat64).requires_grad_()};
  const auto folded = map->forward(features, pose, projection);
  const auto projected = map->forward(torch::linear(features, projection.weight, projection.bias), pose);
  EXPECT_TRUE(torch::allclose(folded, projected, 1e-12, 1e-12));
  const auto weights = torch::randn_like(folded);
  const auto grads_folded = torch::autograd::grad({(folded * weights).sum()},
                                                  {features, projection.weight, projection.bias, p["last.weight"]});
  const auto grads_projected = torch::autograd::grad(
      {(projected * weights).sum()}, {features, projection.weight, projection.bias, p["last.weight"]});
  for (size_t i = 0; i < grads_folded.size(); ++i) {
    EXPECT_TRUE(torch::allclose(grads_folded[i], grads_projected[i], 1e-10, 1e-12)) << "gradient " << i;
  }
}

TEST(OperationMap, RejectsBadShapes) {
  OperationMap map(small_options(1));
  testing::expect_error([&] { map->forward(torch::zeros({2, 5, 9}), torch::zeros({2, 10})); },
                        {"OperationMap: space embedding", "[2, 5, 9]"});
  testing::expect_error([&] { map->forward(torch::zeros({2, 5, 10}), torch::zeros({3, 10})); },
                        {"OperationMap: pose embedding", "[2, 10]", "[3, 10]"});
  const SpaceProjection projection{torch::zeros({10, 7}), torch::zeros({10})};
  testing::expect_error([&] { map->forward(torch::zeros({2, 5, 6}), torch::zeros({2, 10}), projection); },
                        {"OperationMap: space features", "[*, *, 7]", "[2, 5, 6]"});
  testing::expect_error(
      [&] { map->forward(torch::zeros({2, 5, 7}), torch::zeros({2, 10}), {torch::zeros({9, 7}), torch::zeros({10})}); },
      {"OperationMap: space projection weight", "[9, 7]"});
  auto o = small_options(1);
  o.hidden_layers = 0;
  testing::expect_error([&] { OperationMap{o}; }, {"OperationMapOptions", "hidden_layers"});
}

}  // namespace
}  // namespace fskin
