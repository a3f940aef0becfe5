#include "fskin/invertible/coupling_layer.h"

#include <gtest/gtest.h>

#include "fskin/core/error.h"
#include "invertible/invertible_test_util.h"
#include "test_util.h"

namespace fskin {
namespace {

// Every split of the PIN schedule (three 2D planes, three 1D axes), each with
// a sine and a linear SIREN output (the latter folded into the maps).
std::vector<std::shared_ptr<CouplingLayer>> all_layers(torch::Dtype dtype, bool randomize) {
  std::vector<std::shared_ptr<CouplingLayer>> layers;
  for (bool linear : {false, true}) {
    CouplingLayerOptions o;
    o.space_linear_output = linear;
    for (auto plane : {std::pair<int64_t, int64_t>{0, 1}, {1, 2}, {2, 0}}) {
      layers.push_back(std::make_shared<CouplingLayer2D>(plane.first, plane.second, o));
    }
    for (int64_t axis : {0, 1, 2}) layers.push_back(std::make_shared<CouplingLayer1D>(axis, o));
  }
  for (auto& layer : layers) {
    layer->to(dtype);
    if (randomize) testing::randomize_parameters(*layer);
  }
  return layers;
}

std::string describe(const CouplingLayer& layer) {
  std::string s = layer.moved().size() == 2 ? "2D moving" : "1D moving";
  for (int64_t a : layer.moved()) s += " " + std::to_string(a);
  return s + (layer.options().space_linear_output ? ", linear SIREN output" : ", sine SIREN output");
}

double max_abs(const torch::Tensor& t) { return t.abs().max().item<double>(); }

TEST(CouplingLayer, SplitsTheCoordinates) {
  CouplingLayer2D plane(2, 0);
  EXPECT_EQ(plane.moved(), (std::vector<int64_t>{2, 0}));
  EXPECT_EQ(plane.kept(), (std::vector<int64_t>{1}));
  CouplingLayer1D axis(1);
  EXPECT_EQ(axis.kept(), (std::vector<int64_t>{0, 2}));
}

TEST(CouplingLayer, IsTheIdentityAtInitialisation) {
  torch::manual_seed(0);
  const auto x = torch::randn({2, 64, 3});
  const auto pose = torch::randn({2, 120});
  for (auto& layer : all_layers(torch::kFloat32, false)) {
    EXPECT_TRUE(torch::equal(layer->forward(x, pose), x)) << describe(*layer);
    EXPECT_TRUE(torch::equal(layer->inverse(x, pose), x)) << describe(*layer);
  }
}

TEST(CouplingLayer, InverseUndoesForwardAfterRandomisation) {
  torch::manual_seed(1);
  for (auto dtype : {torch::kFloat64, torch::kFloat32}) {
    const double tolerance = dtype == torch::kFloat64 ? 1e-12 : 1e-5;
    const auto x = torch::randn({2, 64, 3}, dtype);
    const auto pose = torch::randn({2, 120}, dtype) * 0.5;
    for (auto& layer : all_layers(dtype, true)) {
      const auto y = layer->forward(x, pose);
      EXPECT_GT(max_abs(y - x), 1e-2) << describe(*layer) << ": the test needs a layer that moves points";
      EXPECT_LT(max_abs(layer->inverse(y, pose) - x), tolerance) << describe(*layer);
      EXPECT_LT(max_abs(layer->forward(layer->inverse(x, pose), pose) - x), tolerance) << describe(*layer);
    }
  }
}

TEST(CouplingLayer, KeepsTheConditioningCoordinates) {
  torch::manual_seed(2);
  const auto x = torch::randn({2, 64, 3}, torch::kFloat64);
  const auto pose = torch::randn({2, 120}, torch::kFloat64);
  for (auto& layer : all_layers(torch::kFloat64, true)) {
    const auto y = layer->forward(x, pose);
    for (int64_t axis : layer->kept()) EXPECT_TRUE(torch::equal(y.select(-1, axis), x.select(-1, axis)));
  }
}

TEST(CouplingLayer, MovesEachSliceRigidly) {
  // Points that share the kept coordinates get the same motion (eq. 5, 12):
  // distances among them are preserved.
  torch::manual_seed(3);
  const auto pose = torch::randn({1, 120}, torch::kFloat64);
  for (auto& layer : all_layers(torch::kFloat64, true)) {
    auto x = torch::randn({1, 32, 3}, torch::kFloat64);
    for (int64_t axis : layer->kept()) x.select(-1, axis).fill_(0.37);
    const auto y = layer->forward(x, pose);
    // Direct differences (compute_mode 2), not the |a|^2 + |b|^2 - 2ab matrix
    // product, whose rounding depends on the BLAS kernel.
    EXPECT_TRUE(torch::allclose(torch::cdist(y, y, 2.0, 2), torch::cdist(x, x, 2.0, 2), 1e-12, 1e-12))
        << describe(*layer);
    EXPECT_GT(max_abs(y - x), 1e-2) << describe(*layer);
  }
}

TEST(CouplingLayer, IsTheIdentityAtZeroPoseForAnyParameters) {
  torch::manual_seed(4);
  const auto x = torch::randn({2, 64, 3}, torch::kFloat64);
  const auto zero = torch::zeros({2, 120}, torch::kFloat64);
  for (auto& layer : all_layers(torch::kFloat64, true)) {
    // Exact in arithmetic; the centring's two MLP evaluations (per point and at
    // c = 0) may round differently, so the identity holds to rounding.
    EXPECT_LT(max_abs(layer->forward(x, zero) - x), 1e-14) << describe(*layer);
    EXPECT_LT(max_abs(layer->inverse(x, zero) - x), 1e-14) << describe(*layer);
  }
}

TEST(CouplingLayer, JacobianDeterminantIsOne) {
  // Appendix C.2: block-triangular Jacobian with blocks R and I.
  torch::manual_seed(5);
  const auto x = torch::randn({2, 64, 3}, torch::kFloat64);
  const auto pose = torch::randn({2, 120}, torch::kFloat64);
  for (auto& layer : all_layers(torch::kFloat64, true)) {
    const auto jac = testing::point_jacobians([&](const torch::Tensor& p) { return layer->forward(p, pose); }, x);
    const auto eye = torch::eye(3, torch::kFloat64);
    EXPECT_GT(max_abs(jac - eye), 1e-2) << describe(*layer) << ": the test needs a non-trivial Jacobian";
    EXPECT_LT(max_abs(torch::det(jac) - 1.0), 1e-10) << describe(*layer);
    const auto inv = testing::point_jacobians([&](const torch::Tensor& p) { return layer->inverse(p, pose); }, x);
    EXPECT_LT(max_abs(torch::det(inv) - 1.0), 1e-10) << describe(*layer);
  }
}

TEST(CouplingLayer, GradientsReachEveryParameterAndMatchFiniteDifferences) {
  torch::manual_seed(6);
  auto x = torch::randn({2, 16, 3}, torch::kFloat64);
  auto pose = torch::randn({2, 120}, torch::kFloat64);
  const auto w = torch::randn({2, 16, 3}, torch::kFloat64);
  for (auto& layer : all_layers(torch::kFloat64, true)) {
    for (bool inverse : {false, true}) {
      auto loss = [&] { return ((inverse ? layer->inverse(x, pose) : layer->forward(x, pose)) * w).sum(); };
      layer->zero_grad();
      loss().backward();
      testing::expect_all_parameters_have_gradient(*layer);
      for (const auto& p : layer->named_parameters()) {
        testing::expect_gradient_matches_finite_difference(loss, p.value(), {0, p.value().numel() / 2},
                                                           describe(*layer) + " " + p.key());
      }
      testing::expect_gradient_matches_finite_difference(loss, x, {0, 5, 40}, describe(*layer) + " x");
      testing::expect_gradient_matches_finite_difference(loss, pose, {0, 77}, describe(*layer) + " pose");
    }
  }
}

TEST(CouplingLayer, RejectsBadInputs) {
  CouplingLayer2D layer(0, 1);
  testing::expect_error([&] { layer.forward(torch::zeros({2, 8, 2}), torch::zeros({2, 120})); },
                        {"CouplingLayer: points", "[*, *, 3]", "[2, 8, 2]"});
  testing::expect_error([&] { layer.inverse(torch::zeros({2, 8, 3}), torch::zeros({1, 120})); },
                        {"CouplingLayer: pose embedding", "[2, 120]", "[1, 120]"});
  testing::expect_error([] { CouplingLayer2D(0, 3); }, {"CouplingLayer", "axis 3"});
  testing::expect_error([] { CouplingLayer2D(1, 1); }, {"CouplingLayer", "distinct"});
  CouplingLayerOptions o;
  o.space_layers = 0;
  testing::expect_error([&] { CouplingLayer1D(0, o); }, {"CouplingLayerOptions", "space_layers"});
}

}  // namespace
}  // namespace fskin
