// The fused ray compositing against its LibTorch reference (forward and both
// four gradients), analytic rays, finite differences in float64, and its errors.
#include "fskin/ops/ray_compositing.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <vector>

#include "fskin/core/error.h"
#include "ops/common/dispatcher.h"
#include "test_util.h"

namespace fskin {
namespace {

struct Rays {
  torch::Tensor sigma, rgb, delta, background;
};

Rays random_rays(int64_t rays, int64_t samples, torch::Dtype dtype) {
  Rays r;
  r.sigma = torch::rand({rays, samples}, dtype) * 8;
  r.rgb = torch::rand({rays, samples, 3}, dtype);
  r.delta = torch::rand({rays, samples}, dtype) * 0.05;
  // The last quarter of every ray is padding (delta 0).
  r.delta.narrow(1, samples - samples / 4, samples / 4).zero_();
  r.background = torch::rand({rays, 3}, dtype);
  return r;
}

TEST(RayCompositing, MatchesTheLibTorchReferenceForwardAndBackward) {
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    torch::manual_seed(0);
    const auto rays = random_rays(700, 64, dtype);
    const auto s1 = rays.sigma.clone().requires_grad_(true), c1 = rays.rgb.clone().requires_grad_(true);
    const auto s2 = rays.sigma.clone().requires_grad_(true), c2 = rays.rgb.clone().requires_grad_(true);
    const auto [color1, opacity1] = composite_rays(s1, c1, rays.delta, rays.background);
    const auto [color2, opacity2] = composite_rays_reference(s2, c2, rays.delta, rays.background);
    const double tolerance = dtype == torch::kFloat64 ? 1e-12 : 2e-6;
    EXPECT_LT((color1 - color2).abs().max().item<double>(), tolerance);
    EXPECT_LT((opacity1 - opacity2).abs().max().item<double>(), tolerance);
    const auto gc = torch::randn_like(color1), ga = torch::randn_like(opacity1);
    ((color1 * gc).sum() + (opacity1 * ga).sum()).backward();
    ((color2 * gc).sum() + (opacity2 * ga).sum()).backward();
    EXPECT_LT((s1.grad() - s2.grad()).abs().max().item<double>(), 10 * tolerance);
    EXPECT_LT((c1.grad() - c2.grad()).abs().max().item<double>(), tolerance);
    // Padding gets no gradient from sigma.
    EXPECT_EQ(s1.grad().narrow(1, 48, 16).abs().max().item<double>(), 0.0);
  }
}

TEST(RayCompositing, AHomogeneousSlabRendersItsAnalyticColour) {
  // Density 3 over length 0.5 in colour (0.2, 0.5, 0.9) before a white background:
  // opacity 1 - exp(-1.5), whatever the number of samples.
  const double sigma = 3, length = 0.5;
  for (const int64_t samples : {1, 7, 100}) {
    const auto s = torch::full({1, samples}, sigma, torch::kFloat64);
    const auto d = torch::full({1, samples}, length / static_cast<double>(samples), torch::kFloat64);
    const auto c = torch::tensor({0.2, 0.5, 0.9}, torch::kFloat64).expand({1, samples, 3}).contiguous();
    const auto [color, opacity] = composite_rays(s, c, d, torch::ones({1, 3}, torch::kFloat64));
    const double a = 1 - std::exp(-sigma * length);
    EXPECT_NEAR(opacity.item<double>(), a, 1e-12);
    EXPECT_NEAR(color[0][0].item<double>(), a * 0.2 + (1 - a), 1e-12);
    EXPECT_NEAR(color[0][2].item<double>(), a * 0.9 + (1 - a), 1e-12);
  }
}

TEST(RayCompositing, ALinearDensityRampConvergesToItsIntegral) {
  // sigma(t) = k t, colour(t) = t on [0, 1]: T(t) = exp(-k t^2 / 2),
  // colour = int_0^1 k t exp(-k t^2 / 2) t dt, by midpoint samples.
  const double k = 4;
  const int64_t samples = 2000;
  const auto t = (torch::arange(samples, torch::kFloat64) + 0.5) / static_cast<double>(samples);
  const auto s = (k * t).unsqueeze(0);
  const auto d = torch::full({1, samples}, 1.0 / samples, torch::kFloat64);
  const auto c = t.view({1, samples, 1}).expand({1, samples, 3}).contiguous();
  const auto [color, opacity] = composite_rays(s, c, d, torch::zeros({1, 3}, torch::kFloat64));
  // Reference integral by a fine trapezoid rule.
  const auto u = torch::linspace(0, 1, 200001, torch::kFloat64);
  const auto integrand = k * u * torch::exp(-k * u * u / 2) * u;
  const double integral = torch::trapezoid(integrand, u).item<double>();
  EXPECT_NEAR(color[0][1].item<double>(), integral, 2e-3);
  EXPECT_NEAR(opacity.item<double>(), 1 - std::exp(-k / 2), 2e-3);
}

TEST(RayCompositing, FiniteDifferencesFloat64InEveryInput) {
  torch::manual_seed(2);
  const auto rays = random_rays(3, 8, torch::kFloat64);
  const std::vector<torch::Tensor> inputs = {rays.sigma, rays.rgb, rays.delta, rays.background};
  const char* names[] = {"sigma", "rgb", "delta", "background"};
  const auto gc = torch::randn({3, 3}, torch::kFloat64), ga = torch::randn({3}, torch::kFloat64);
  const auto loss = [&](const std::vector<torch::Tensor>& x) {
    const auto [color, opacity] = composite_rays(x[0], x[1], x[2], x[3]);
    return (color * gc).sum() + (opacity * ga).sum();
  };
  std::vector<torch::Tensor> leaves;
  for (const auto& input : inputs) leaves.push_back(input.clone().requires_grad_(true));
  loss(leaves).backward();
  const double eps = 1e-6;
  for (size_t which = 0; which < inputs.size(); ++which) {
    ASSERT_TRUE(leaves[which].grad().defined()) << names[which];
    for (int64_t i = 0; i < inputs[which].numel(); ++i) {
      auto plus = inputs, minus = inputs;
      plus[which] = inputs[which].clone();
      minus[which] = inputs[which].clone();
      plus[which].view(-1)[i] += eps;
      minus[which].view(-1)[i] -= eps;
      // delta's padding (0) differenced at -eps would be a negative length; one-sided there.
      const bool one_sided = which == 2 && inputs[which].view(-1)[i].item<double>() == 0;
      if (one_sided) minus[which] = inputs[which];
      torch::NoGradGuard no_grad;
      const double numeric = (loss(plus) - loss(minus)).item<double>() / (one_sided ? eps : 2 * eps);
      EXPECT_NEAR(leaves[which].grad().view(-1)[i].item<double>(), numeric, one_sided ? 1e-4 : 1e-7)
          << names[which] << " " << i;
    }
  }
}

TEST(RayCompositing, GradientsOfDeltaAndBackgroundMatchTheReference) {
  torch::manual_seed(4);
  const auto rays = random_rays(50, 16, torch::kFloat64);
  const auto d1 = rays.delta.clone().requires_grad_(true), b1 = rays.background.clone().requires_grad_(true);
  const auto d2 = rays.delta.clone().requires_grad_(true), b2 = rays.background.clone().requires_grad_(true);
  const auto [color1, opacity1] = composite_rays(rays.sigma, rays.rgb, d1, b1);
  const auto [color2, opacity2] = composite_rays_reference(rays.sigma, rays.rgb, d2, b2);
  const auto gc = torch::randn_like(color1), ga = torch::randn_like(opacity1);
  ((color1 * gc).sum() + (opacity1 * ga).sum()).backward();
  ((color2 * gc).sum() + (opacity2 * ga).sum()).backward();
  EXPECT_LT((d1.grad() - d2.grad()).abs().max().item<double>(), 1e-11);
  EXPECT_LT((b1.grad() - b2.grad()).abs().max().item<double>(), 1e-12);
  EXPECT_GT(b1.grad().abs().max().item<double>(), 0.0);
}

TEST(RayCompositing, BadInputsAreErrorsThatSayWhat) {
  const auto r = random_rays(4, 8, torch::kFloat32);
  testing::expect_error([&] { composite_rays(r.sigma, r.rgb.narrow(2, 0, 2), r.delta, r.background); },
                        {"composite_rays: rgb"});
  testing::expect_error([&] { composite_rays(r.sigma, r.rgb, r.delta.narrow(1, 0, 4), r.background); },
                        {"composite_rays: delta"});
  testing::expect_error([&] { composite_rays(r.sigma, r.rgb.to(torch::kFloat64), r.delta, r.background); },
                        {"one dtype"});
  testing::expect_error([&] { composite_rays(r.sigma.to(torch::kInt32), r.rgb, r.delta, r.background); },
                        {"float32 or float64"});
  const auto [color, opacity] =
      composite_rays(torch::zeros({0, 8}), torch::zeros({0, 8, 3}), torch::zeros({0, 8}), torch::zeros({0, 3}));
  EXPECT_EQ(color.size(0), 0);
  EXPECT_EQ(opacity.size(0), 0);
}

TEST(RayCompositing, IsAnOperatorInPyTorchsDispatcherWithItsOwnBackward) {
  // Called by name through the dispatcher, as torch.ops.fskin.composite_rays
  // and TorchScript call it: the same values and gradients as the C++ entry.
  torch::manual_seed(3);
  const auto rays = random_rays(50, 16, torch::kFloat64);
  using Signature = std::tuple<torch::Tensor, torch::Tensor>(const torch::Tensor&, const torch::Tensor&,
                                                             const torch::Tensor&, const torch::Tensor&);
  const auto op = fskin_operator<Signature>("fskin::composite_rays");
  const auto sigma = rays.sigma.clone().requires_grad_(true);
  const auto reference_sigma = rays.sigma.clone().requires_grad_(true);
  const auto [color, opacity] = op.call(sigma, rays.rgb, rays.delta, rays.background);
  const auto [expected_color, expected_opacity] =
      composite_rays_reference(reference_sigma, rays.rgb, rays.delta, rays.background);
  EXPECT_TRUE(torch::allclose(color, expected_color, 0, 1e-12));
  EXPECT_TRUE(torch::allclose(opacity, expected_opacity, 0, 1e-12));
  const auto loss = color.sum() + opacity.sum();
  const auto grad = torch::autograd::grad({loss}, {sigma}, {}, /*retain_graph=*/true)[0];
  const auto expected_grad = torch::autograd::grad({expected_color.sum() + expected_opacity.sum()}, {reference_sigma})[0];
  EXPECT_TRUE(torch::allclose(grad, expected_grad, 0, 1e-10));
  // The backward is an op too, and says it has no derivative of its own.
  EXPECT_THROW(torch::autograd::grad({loss}, {sigma}, {}, true, /*create_graph=*/true), std::exception);
}

}  // namespace
}  // namespace fskin
