#include "fskin/networks/siren.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fskin/core/error.h"
#include "test_util.h"

namespace fskin {
namespace {

TEST(Siren, LayersAreSinesOfScaledAffineMaps) {
  torch::manual_seed(0);
  SirenOptions o;
  o.input_dim = 2;
  o.hidden_dim = 8;
  o.output_dim = 5;
  o.num_layers = 2;
  o.first_omega = 30.0;
  o.hidden_omega = 7.0;
  Siren siren(o);
  siren->to(torch::kFloat64);
  const auto params = siren->named_parameters();
  const auto x = torch::rand({4, 6, 2}, torch::kFloat64) * 2 - 1;
  const auto h = torch::sin(30.0 * torch::linear(x, params["linear0.weight"], params["linear0.bias"]));
  const auto expected = torch::sin(7.0 * torch::linear(h, params["linear1.weight"], params["linear1.bias"]));
  const auto y = siren->forward(x);
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{4, 6, 5}));
  EXPECT_TRUE(torch::allclose(y, expected, 1e-12, 1e-12));
}

TEST(Siren, InitialisationFollowsTheSirenPaper) {
  torch::manual_seed(1);
  SirenOptions o;
  o.input_dim = 2;
  o.hidden_dim = 256;
  o.output_dim = 120;
  o.num_layers = 3;
  Siren siren(o);
  const auto params = siren->named_parameters();
  // First layer U(-1/in, 1/in); later layers U(-sqrt(6/in)/w0, sqrt(6/in)/w0).
  const double first = 1.0 / 2.0, later = std::sqrt(6.0 / 256.0) / 30.0;
  for (const auto& [name, bound] : std::vector<std::pair<std::string, double>>{
           {"linear0.weight", first}, {"linear1.weight", later}, {"linear2.weight", later}}) {
    const double max = params[name].abs().max().item<double>();
    EXPECT_LE(max, bound) << name;
    EXPECT_GT(max, 0.9 * bound) << name;  // uses the whole range, not a narrower init
  }
}

TEST(Siren, OutputIsABoundedEmbedding) {
  torch::manual_seed(2);
  SirenOptions o;
  o.input_dim = 1;
  Siren siren(o);
  const auto y = siren->forward(torch::randn({3, 100, 1}) * 5);
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{3, 100, 120}));
  EXPECT_LE(y.abs().max().item<double>(), 1.0);
  // The first layer's w0 = 30 makes the embedding vary on a centimetre scale.
  const auto near = siren->forward(torch::full({1, 1, 1}, 0.01)) - siren->forward(torch::zeros({1, 1, 1}));
  EXPECT_GT(near.abs().max().item<double>(), 0.05);
}

TEST(Siren, LinearOutputIsTheLastAffineMapOfTheHiddenFeatures) {
  torch::manual_seed(3);
  SirenOptions o;
  o.input_dim = 2;
  o.hidden_dim = 64;
  o.output_dim = 40;
  o.num_layers = 2;
  o.linear_output = true;
  Siren siren(o);
  siren->to(torch::kFloat64);
  const auto params = siren->named_parameters();
  const auto x = torch::rand({3, 500, 2}, torch::kFloat64) * 2 - 1;
  const auto h = torch::sin(30.0 * torch::linear(x, params["linear0.weight"], params["linear0.bias"]));
  EXPECT_TRUE(torch::allclose(siren->hidden(x), h, 1e-12, 1e-12));
  const auto y = siren->forward(x);
  EXPECT_TRUE(torch::allclose(y, torch::linear(h, params["linear1.weight"], params["linear1.bias"]), 1e-12, 1e-12));
  EXPECT_TRUE(torch::allclose(y, siren->output_layer()->forward(siren->hidden(x)), 0, 0));
  // Initialised without the 1/w0 of a sine layer: W h has about unit variance,
  // not 1/w0^2 (bias adds ~1/(3 in) on top).
  const double variance = (y - params["linear1.bias"]).var().item<double>();
  EXPECT_GT(variance, 0.5);
  EXPECT_LT(variance, 2.0);
  EXPECT_GT(y.abs().max().item<double>(), 1.0);  // not a bounded sine output
}

TEST(Siren, RejectsBadOptionsAndInputs) {
  SirenOptions o;
  o.num_layers = 0;
  testing::expect_error([&] { Siren{o}; }, {"SirenOptions", "num_layers"});
  o.num_layers = 2;
  o.first_omega = 0;
  testing::expect_error([&] { Siren{o}; }, {"SirenOptions", "first_omega"});
  o.first_omega = 30;
  o.num_layers = 1;
  o.linear_output = true;
  testing::expect_error([&] { Siren{o}; }, {"SirenOptions", "linear_output", "num_layers >= 2"});
  o.num_layers = 2;
  o.linear_output = false;
  Siren siren(o);
  testing::expect_error([&] { siren->forward(torch::zeros({4, 2})); }, {"Siren", "[..., 3]", "[4, 2]"});
}

}  // namespace
}  // namespace fskin
