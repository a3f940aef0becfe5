#include "fskin/networks/mlp.h"

#include <gtest/gtest.h>

#include "fskin/core/error.h"

namespace fskin {
namespace {

TEST(Mlp, ShapesWithSkipAndCondition) {
  torch::manual_seed(0);
  MlpOptions o;
  o.input_dim = 5;
  o.output_dim = 2;
  o.hidden_dim = 32;
  o.hidden_layers = 4;
  o.skip_layers = {2};
  o.condition_dim = 4;
  o.condition_layer = 2;
  Mlp mlp(o);
  const auto y = mlp->forward(torch::randn({7, 11, 5}), torch::randn({7, 11, 4}));
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{7, 11, 2}));
  // Five weight-normalised layers: direction, magnitude and bias each.
  EXPECT_EQ(mlp->parameters().size(), 15u);
  EXPECT_THROW(mlp->forward(torch::randn({3, 5})), Error);                       // condition missing
  EXPECT_THROW(mlp->forward(torch::randn({3, 4}), torch::randn({3, 4})), Error);  // wrong input width
}

TEST(Mlp, ConditionChangesTheOutput) {
  torch::manual_seed(1);
  MlpOptions o;
  o.hidden_dim = 16;
  o.hidden_layers = 2;
  o.condition_dim = 2;
  o.condition_layer = 1;
  Mlp mlp(o);
  const auto x = torch::randn({5, 3});
  EXPECT_FALSE(torch::allclose(mlp->forward(x, torch::zeros({5, 2})), mlp->forward(x, torch::ones({5, 2}))));
}

TEST(Mlp, WeightNormMagnitudeScalesTheLayer) {
  torch::manual_seed(2);
  WeightNormLinear layer(3, 4);
  const auto x = torch::randn({6, 3});
  const auto before = layer->forward(x) - layer->bias;
  {
    torch::NoGradGuard no_grad;
    layer->magnitude.mul_(2.0);
    layer->direction.mul_(5.0);  // the direction's norm does not matter
  }
  EXPECT_TRUE(torch::allclose(layer->forward(x) - layer->bias, 2 * before, 1e-5, 1e-5));
}

TEST(Mlp, GeometricInitIsPositiveInsideTheSphere) {
  torch::manual_seed(3);
  MlpOptions o;
  o.hidden_dim = 256;
  o.hidden_layers = 8;
  o.skip_layers = {4};
  o.geometric_init = true;
  o.geometric_init_radius = 0.5;
  Mlp mlp(o);
  const auto dirs = torch::nn::functional::normalize(torch::randn({200, 3}),
                                                     torch::nn::functional::NormalizeFuncOptions().dim(1));
  torch::NoGradGuard no_grad;
  EXPECT_TRUE((mlp->forward(dirs * 0.1) > 0).all().item<bool>());
  EXPECT_TRUE((mlp->forward(dirs * 1.0) < 0).all().item<bool>());
}

TEST(Mlp, RejectsBadOptions) {
  MlpOptions o;
  o.skip_layers = {0};
  EXPECT_THROW(Mlp{o}, Error);
  o.skip_layers = {};
  o.condition_dim = 2;
  o.condition_layer = 99;
  EXPECT_THROW(Mlp{o}, Error);
}

}  // namespace
}  // namespace fskin
