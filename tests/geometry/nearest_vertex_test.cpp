#include "fskin/geometry/nearest_vertex.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "test_util.h"

namespace fskin {
namespace {

TEST(NearestVertices, MatchBruteForce) {
  torch::manual_seed(0);
  // A thin, flat cloud (like a low-poly ear) and queries around and far from it.
  const auto vertices = torch::rand({3000, 3}) * torch::tensor({1.0, 0.6, 0.02});
  const auto queries = torch::rand({5000, 3}) * 2 - 0.5;
  const auto nearest = nearest_vertices(queries, vertices.to(torch::kFloat64));
  const auto [truth_distance, truth_index] = torch::cdist(queries, vertices).min(1);
  ASSERT_EQ(nearest.index.sizes(), (std::vector<int64_t>{5000}));
  EXPECT_LT((nearest.distance - truth_distance).abs().max().item<double>(), 1e-5);
  // The index found is a nearest one: its distance is the minimum.
  const auto found = (queries - vertices.index_select(0, nearest.index)).norm(2, 1);
  EXPECT_LT((found - truth_distance).abs().max().item<double>(), 1e-5);
  EXPECT_EQ(nearest_vertices(vertices.narrow(0, 0, 10), vertices).distance.abs().max().item<double>(), 0.0);
}

TEST(NearestVertices, BadInputIsNamed) {
  testing::expect_error([] { nearest_vertices(torch::zeros({2, 3}), torch::zeros({0, 3})); }, {"no vertices"});
  testing::expect_error([] { nearest_vertices(torch::zeros({2, 2}), torch::zeros({4, 3})); }, {"queries"});
  auto bad = torch::zeros({4, 3});
  bad[1][2] = NAN;
  testing::expect_error([&] { nearest_vertices(torch::zeros({2, 3}), bad); }, {"vertices", "non-finite"});
}

}  // namespace
}  // namespace fskin
