// The fused hash encoding against its LibTorch reference (forward and both
// gradients), finite differences in float64, its per-point core called
// directly, and its errors.
#include "fskin/ops/hash_encoding.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "ops/hash_encoding/hash_encoding_kernel.h"
#include "test_util.h"

namespace fskin {
namespace {

// Resolutions 2, 4, 8, 16, 32 with 2^10 rows: three dense levels, two hashed.
HashEncodingOptions small_options() {
  HashEncodingOptions o;
  o.levels = 5;
  o.features_per_level = 2;
  o.log2_table_size = 10;
  o.base_resolution = 2;
  o.per_level_scale = 2.0;
  return o;
}

TEST(HashEncoding, LevelsAreDenseWhileTheyFitThenHashed) {
  const auto o = small_options();
  EXPECT_EQ(o.resolution(0), 2);
  EXPECT_EQ(o.resolution(4), 32);
  EXPECT_FALSE(o.hashed(2));  // 9^3 = 729 <= 1024
  EXPECT_TRUE(o.hashed(3));   // 17^3 > 1024
  EXPECT_EQ(o.output_dim(), 10);
}

TEST(HashEncoding, MatchesTheLibTorchReferenceForwardAndBackward) {
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    torch::manual_seed(0);
    const auto o = small_options();
    // Inside the cube, and some outside it (clamped).
    auto positions = torch::rand({3000, 3}, dtype) * 1.2 - 0.1;
    auto table = torch::randn({o.levels, o.table_size(), o.features_per_level}, dtype);
    const auto p1 = positions.clone().requires_grad_(true), t1 = table.clone().requires_grad_(true);
    const auto p2 = positions.clone().requires_grad_(true), t2 = table.clone().requires_grad_(true);
    const auto fused = hash_encoding(p1, t1, o);
    const auto reference = hash_encoding_reference(p2, t2, o);
    const double tolerance = dtype == torch::kFloat64 ? 1e-12 : 1e-5;
    EXPECT_LT((fused - reference).abs().max().item<double>(), tolerance);
    const auto weights = torch::randn_like(fused);
    (fused * weights).sum().backward();
    (reference * weights).sum().backward();
    EXPECT_LT((t1.grad() - t2.grad()).abs().max().item<double>(), 10 * tolerance);
    EXPECT_LT((p1.grad() - p2.grad()).abs().max().item<double>(), 100 * tolerance * o.resolution(o.levels - 1));
    // Clamped coordinates get no gradient.
    const auto outside = (positions < 0) | (positions > 1);
    EXPECT_EQ(p1.grad().masked_select(outside).abs().max().item<double>(), 0.0);
  }
}

TEST(HashEncoding, GradcheckFloat64) {
  torch::manual_seed(1);
  auto o = small_options();
  o.levels = 4;
  o.log2_table_size = 6;  // hashed from the second level
  const auto positions = (torch::rand({6, 3}, torch::kFloat64) * 0.8 + 0.1).requires_grad_(true);
  const auto table = torch::randn({o.levels, o.table_size(), o.features_per_level}, torch::kFloat64).requires_grad_(true);
  const auto analytic = [&] {
    positions.mutable_grad() = torch::Tensor();
    table.mutable_grad() = torch::Tensor();
    const auto out = hash_encoding(positions, table, o);
    out.square().sum().backward();
    return std::make_pair(positions.grad().clone(), table.grad().clone());
  }();
  // Central differences of the same scalar.
  const auto loss = [&](const torch::Tensor& p, const torch::Tensor& t) {
    torch::NoGradGuard no_grad;
    return hash_encoding(p, t, o).square().sum().item<double>();
  };
  const double eps = 1e-6;
  for (int64_t i = 0; i < positions.numel(); ++i) {
    auto plus = positions.detach().clone(), minus = positions.detach().clone();
    plus.view(-1)[i] += eps;
    minus.view(-1)[i] -= eps;
    const double numeric = (loss(plus, table.detach()) - loss(minus, table.detach())) / (2 * eps);
    EXPECT_NEAR(analytic.first.view(-1)[i].item<double>(), numeric, 1e-5 * std::max(1.0, std::abs(numeric))) << i;
  }
  // The table: the rows the points touch (the others have zero gradient).
  const auto touched = analytic.second.abs().sum(-1).view(-1).nonzero().squeeze(1);
  ASSERT_GT(touched.numel(), 0);
  for (int64_t k = 0; k < std::min<int64_t>(touched.numel(), 40); ++k) {
    const int64_t row = touched[k].item<int64_t>();
    for (int64_t f = 0; f < o.features_per_level; ++f) {
      const int64_t i = row * o.features_per_level + f;
      auto plus = table.detach().clone(), minus = table.detach().clone();
      plus.view(-1)[i] += eps;
      minus.view(-1)[i] -= eps;
      const double numeric = (loss(positions.detach(), plus) - loss(positions.detach(), minus)) / (2 * eps);
      EXPECT_NEAR(analytic.second.view(-1)[i].item<double>(), numeric, 1e-6 * std::max(1.0, std::abs(numeric)));
    }
  }
}

TEST(HashEncoding, AGridVertexOfADenseLevelReadsItsRow) {
  const auto o = small_options();
  const auto table = torch::randn({o.levels, o.table_size(), o.features_per_level}, torch::kFloat64);
  // Vertex (1, 2, 0) of level 1 (resolution 4, 5 vertices per axis): row 1 + 5 * 2.
  const auto p = torch::tensor({{0.25, 0.5, 0.0}}, torch::kFloat64);
  const auto features = hash_encoding(p, table, o);
  const auto expected = table[1][1 + 5 * 2];
  EXPECT_TRUE(torch::allclose(features[0].narrow(0, 2, 2), expected, 0, 1e-14));
}

TEST(HashEncoding, CellWeightsArePartitionsOfUnityAndTheirDerivativesCancel) {
  hash_grid::Cell<double> cell;
  const double p[3] = {0.3141, 0.2718, 0.777};
  hash_grid::locate(p, 16, true, 1 << 10, true, cell);
  double sum = 0, d[3] = {0, 0, 0};
  for (int c = 0; c < 8; ++c) {
    EXPECT_GE(cell.weight[c], 0.0);
    EXPECT_GE(cell.row[c], 0);
    EXPECT_LT(cell.row[c], 1 << 10);
    sum += cell.weight[c];
    for (int a = 0; a < 3; ++a) d[a] += cell.derivative[c][a];
  }
  EXPECT_NEAR(sum, 1.0, 1e-14);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(d[a], 0.0, 1e-12);
  // The hash of the kernel: x xor y * 2654435761 xor z * 805459861, low bits.
  EXPECT_EQ(hash_grid::vertex_row(3, 5, 7, 16, true, 1 << 10),
            static_cast<int64_t>((3u ^ (5u * 2654435761u) ^ (7u * 805459861u)) & 1023u));
}

TEST(HashEncoding, BadInputsAreErrorsThatSayWhat) {
  const auto o = small_options();
  const auto table = torch::zeros({o.levels, o.table_size(), o.features_per_level});
  testing::expect_error([&] { hash_encoding(torch::zeros({4, 2}), table, o); }, {"hash_encoding: positions"});
  testing::expect_error([&] { hash_encoding(torch::zeros({4, 3}), table.narrow(1, 0, 10), o); },
                        {"hash_encoding: table"});
  testing::expect_error([&] { hash_encoding(torch::zeros({4, 3}, torch::kFloat64), table, o); }, {"one dtype"});
  auto bad = o;
  bad.levels = 40;
  testing::expect_error([&] { hash_encoding(torch::zeros({4, 3}), table, bad); }, {"levels 40"});
  auto nan = torch::zeros({4, 3});
  nan[2][1] = std::numeric_limits<float>::quiet_NaN();
  testing::expect_error([&] { hash_encoding(nan, table, o); }, {"non-finite"});
  EXPECT_EQ(hash_encoding(torch::zeros({0, 3}), table, o).sizes(), (std::vector<int64_t>{0, 10}));
}

}  // namespace
}  // namespace fskin
