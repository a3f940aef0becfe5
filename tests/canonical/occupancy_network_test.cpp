#include "fskin/canonical/occupancy_network.h"
#include "fskin/networks/frequency_encoding.h"

#include <gtest/gtest.h>

#include "test_util.h"

namespace fskin {
namespace {

OccupancyNetworkOptions small(int64_t pose_dim) {
  OccupancyNetworkOptions o = OccupancyNetworkOptions::demo(pose_dim);
  o.hidden_dim = 64;
  o.init_radius = 0.5;
  return o;
}

TEST(OccupancyNetwork, GeometricInitIsASphere) {
  torch::manual_seed(0);
  OccupancyNetwork net(small(6));
  const auto pose = torch::randn({2, 6});
  const auto inside = torch::randn({2, 50, 3}) * 0.05;
  const auto outside = torch::nn::functional::normalize(torch::randn({2, 50, 3}),
                                                        torch::nn::functional::NormalizeFuncOptions().dim(-1)) * 0.9;
  const auto li = net->forward(inside, pose), lo = net->forward(outside, pose);
  EXPECT_EQ(li.sizes(), (std::vector<int64_t>{2, 50}));
  EXPECT_TRUE((li > 0).all().item<bool>());
  EXPECT_TRUE((lo < 0).all().item<bool>());
}

TEST(OccupancyNetwork, PoseConditioningReachesTheOutput) {
  torch::manual_seed(1);
  OccupancyNetwork net(small(6));
  const auto x = torch::randn({1, 4, 2, 3}) * 0.3;
  const auto a = torch::zeros({1, 6}), b = torch::ones({1, 6});
  // Geometric init ignores the condition; a gradient step makes it matter.
  EXPECT_TRUE(torch::allclose(net->forward(x, a), net->forward(x, b)));
  torch::optim::SGD sgd(net->parameters(), 0.1);
  net->forward(x, b).sum().backward();
  sgd.step();
  EXPECT_FALSE(torch::allclose(net->forward(x, a), net->forward(x, b), 1e-6, 1e-6));
  EXPECT_EQ(net->forward(x, a).sizes(), (std::vector<int64_t>{1, 4, 2}));
}

TEST(OccupancyNetwork, PositionalEncodingAndPoseFree) {
  OccupancyNetworkOptions o = small(0);
  o.encoding_frequencies = 4;
  OccupancyNetwork net(o);
  EXPECT_EQ(positional_encoding(torch::zeros({5, 3}), 4).size(1), 27);
  EXPECT_EQ(net->forward(torch::zeros({3, 7, 3})).sizes(), (std::vector<int64_t>{3, 7}));
  EXPECT_GT(net->forward(torch::zeros({1, 1, 3})).item<float>(), 0.0f);
}

TEST(OccupancyNetwork, BadInputsNameTheProblem) {
  OccupancyNetwork net(small(6));
  testing::expect_error([&] { net->forward(torch::zeros({1, 4, 3})); }, {"pose must be [1, 6]"});
  testing::expect_error([&] { net->forward(torch::zeros({1, 4, 2}), torch::zeros({1, 6})); }, {"[B, ..., 3]"});
  OccupancyNetworkOptions bad = small(6);
  bad.pose_layer = 9;
  testing::expect_error([&] { OccupancyNetwork n(bad); }, {"pose_layer 9"});
}

}  // namespace
}  // namespace fskin
