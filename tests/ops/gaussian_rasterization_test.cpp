// The Gaussian rasteriser against its dense LibTorch reference (forward and
// every gradient), finite differences in float64, a closed-form footprint,
// depth order, the tile lists, determinism across thread counts, and its
// errors.
#include "fskin/ops/gaussian_rasterization.h"

#include <ATen/Parallel.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "ops/common/dispatcher.h"
#include "test_util.h"

namespace fskin {
namespace {

struct Scene {
  torch::Tensor means2d, conics, colors, opacities, depths, radii, background;
  int64_t width = 0, height = 0;
};

// Gaussians with random orientations and widths of 1-6 pixels over a
// `width` x `height` picture (some beyond its edges), radii as the projection
// gives them (3 standard deviations of the widest axis).
Scene random_scene(int64_t gaussians, int64_t width, int64_t height, double max_opacity, torch::Dtype dtype) {
  Scene s;
  s.width = width;
  s.height = height;
  const auto u = torch::rand({gaussians}, torch::kFloat64) * (width + 10) - 5;
  const auto v = torch::rand({gaussians}, torch::kFloat64) * (height + 10) - 5;
  s.means2d = torch::stack({u, v}, 1);
  const auto angle = torch::rand({gaussians}, torch::kFloat64) * M_PI;
  const auto s1 = 1 + 5 * torch::rand({gaussians}, torch::kFloat64), s2 = 1 + 5 * torch::rand({gaussians}, torch::kFloat64);
  const auto cs = torch::cos(angle), sn = torch::sin(angle);
  // Covariance R diag(s1^2, s2^2) R^T.
  const auto a = cs * cs * s1 * s1 + sn * sn * s2 * s2;
  const auto b = cs * sn * (s1 * s1 - s2 * s2);
  const auto c = sn * sn * s1 * s1 + cs * cs * s2 * s2;
  const auto det = a * c - b * b;
  s.conics = torch::stack({c / det, -b / det, a / det}, 1);
  s.radii = torch::ceil(3 * torch::maximum(s1, s2));
  s.colors = torch::rand({gaussians, 3}, torch::kFloat64);
  s.opacities = 0.05 + (max_opacity - 0.05) * torch::rand({gaussians}, torch::kFloat64);
  s.depths = torch::rand({gaussians}, torch::kFloat64) * 10;
  s.background = torch::rand({3}, torch::kFloat64);
  for (auto* t : {&s.means2d, &s.conics, &s.colors, &s.opacities, &s.depths, &s.radii, &s.background}) {
    *t = t->to(dtype);
  }
  return s;
}

using Rasterizer = std::tuple<torch::Tensor, torch::Tensor> (*)(
    const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&,
    const torch::Tensor&, const torch::Tensor&, int64_t, int64_t);

struct Rendered {
  torch::Tensor image, alpha;
  std::vector<torch::Tensor> grads;  // means2d, conics, colors, opacities, background
};

Rendered render_with_gradients(Rasterizer rasterize, const Scene& s, const torch::Tensor& grad_image,
                               const torch::Tensor& grad_alpha) {
  std::vector<torch::Tensor> inputs;
  for (const auto* t : {&s.means2d, &s.conics, &s.colors, &s.opacities, &s.background}) {
    inputs.push_back(t->clone().requires_grad_(true));
  }
  Rendered r;
  std::tie(r.image, r.alpha) =
      rasterize(inputs[0], inputs[1], inputs[2], inputs[3], s.depths, s.radii, inputs[4], s.width, s.height);
  ((r.image * grad_image).sum() + (r.alpha * grad_alpha).sum()).backward();
  for (const auto& t : inputs) r.grads.push_back(t.grad());
  return r;
}

double max_difference(const torch::Tensor& a, const torch::Tensor& b) { return (a - b).abs().max().item<double>(); }

TEST(GaussianRasterization, MatchesTheDenseReferenceForwardAndBackward) {
  const char* names[] = {"means2d", "conics", "colors", "opacities", "background"};
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    torch::manual_seed(3);
    // 300 Gaussians on a 45 x 37 picture (partial tiles on both edges).
    auto scene = random_scene(300, 45, 37, 1.0, dtype);
    scene.radii.narrow(0, 0, 5).zero_();          // not drawn
    scene.opacities.narrow(0, 5, 100).fill_(1.0);  // opaque cores: alpha clamped at 0.99
    const auto grad_image = torch::randn({37, 45, 3}, dtype), grad_alpha = torch::randn({37, 45}, dtype);
    const auto fused = render_with_gradients(&rasterize_gaussians, scene, grad_image, grad_alpha);
    const auto dense = render_with_gradients(&rasterize_gaussians_reference, scene, grad_image, grad_alpha);
    // Layers deep enough that many pixels reach the early stop (T < 1e-3 here
    // means at least two clamped Gaussians and more behind them).
    const auto opaque = (dense.alpha > 1 - 1e-3).sum().item<int64_t>();
    EXPECT_GT(opaque, 100);
    const double tolerance = dtype == torch::kFloat64 ? 1e-11 : 3e-5;
    EXPECT_LT(max_difference(fused.image, dense.image), tolerance);
    EXPECT_LT(max_difference(fused.alpha, dense.alpha), tolerance);
    for (size_t i = 0; i < fused.grads.size(); ++i) {
      const double scale = std::max(1.0, dense.grads[i].abs().max().item<double>());
      EXPECT_LT(max_difference(fused.grads[i], dense.grads[i]), tolerance * scale) << names[i];
    }
    // Gaussians that are not drawn take no gradient.
    EXPECT_EQ(fused.grads[0].narrow(0, 0, 5).abs().max().item<double>(), 0.0);
  }
}

TEST(GaussianRasterization, GradientsMatchFiniteDifferencesInFloat64) {
  torch::manual_seed(11);
  // Few, half-transparent Gaussians: no clamp and no early stop, so the
  // picture is smooth in every input.
  const auto scene = random_scene(6, 21, 18, 0.8, torch::kFloat64);
  const auto grad_image = torch::randn({18, 21, 3}, torch::kFloat64);
  const auto grad_alpha = torch::randn({18, 21}, torch::kFloat64);
  const auto analytic = render_with_gradients(&rasterize_gaussians, scene, grad_image, grad_alpha);
  const auto loss = [&](const Scene& s) {
    const auto [image, alpha] = rasterize_gaussians(s.means2d, s.conics, s.colors, s.opacities, s.depths, s.radii,
                                                    s.background, s.width, s.height);
    return ((image * grad_image).sum() + (alpha * grad_alpha).sum()).item<double>();
  };
  const double eps = 1e-6;
  int checked = 0;
  for (int input = 0; input < 5; ++input) {
    Scene s = scene;
    torch::Tensor* target[] = {&s.means2d, &s.conics, &s.colors, &s.opacities, &s.background};
    const auto original = target[input]->clone();
    for (int64_t k = 0; k < original.numel(); ++k) {
      auto plus = original.clone(), minus = original.clone();
      plus.view({-1})[k] += eps;
      minus.view({-1})[k] -= eps;
      *target[input] = plus;
      const double up = loss(s);
      *target[input] = minus;
      const double down = loss(s);
      const double numeric = (up - down) / (2 * eps);
      const double exact = analytic.grads[input].reshape({-1})[k].item<double>();
      EXPECT_NEAR(exact, numeric, 1e-6 * std::max(1.0, std::abs(numeric))) << "input " << input << " element " << k;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 6 * 2 + 6 * 3 + 6 * 3 + 6 + 3);
}

TEST(GaussianRasterization, AnIsotropicGaussianRendersItsClosedFormFootprint) {
  // One Gaussian of standard deviation 4 pixels at (20.3, 17.6), opacity 0.7,
  // on black: alpha(u, v) = 0.7 exp(-r^2 / 32) within its 12-pixel radius.
  const double sigma = 4, opacity = 0.7, mu = 20.3, mv = 17.6;
  const auto f64 = torch::kFloat64;
  const auto means2d = torch::tensor({mu, mv}, f64).view({1, 2});
  const auto conics = torch::tensor({1 / (sigma * sigma), 0.0, 1 / (sigma * sigma)}, f64).view({1, 3});
  const auto colors = torch::tensor({1.0, 0.5, 0.25}, f64).view({1, 3});
  const auto [image, alpha] =
      rasterize_gaussians(means2d, conics, colors, torch::full({1}, opacity, f64), torch::ones({1}, f64),
                          torch::full({1}, 3 * sigma, f64), torch::zeros({3}, f64), 48, 40);
  const auto a = alpha.accessor<double, 2>();
  int inside = 0;
  for (int v = 0; v < 40; ++v) {
    for (int u = 0; u < 48; ++u) {
      const double r2 = (u - mu) * (u - mu) + (v - mv) * (v - mv);
      if (r2 < 2.5 * 2.5 * sigma * sigma) {
        EXPECT_NEAR(a[v][u], opacity * std::exp(-r2 / (2 * sigma * sigma)), 1e-12) << u << "," << v;
        ++inside;
      } else if (r2 > 4 * 4 * sigma * sigma) {
        EXPECT_EQ(a[v][u], 0.0) << u << "," << v;
      }
    }
  }
  EXPECT_GT(inside, 250);  // pi (2.5 * 4)^2 ~ 314 pixels
  EXPECT_LT(max_difference(image, alpha.unsqueeze(-1) * colors.view({1, 1, 3})), 1e-12);
}

TEST(GaussianRasterization, NearerGaussiansCoverFartherOnesWhateverTheirOrder) {
  const auto f32 = torch::kFloat32;
  const auto means2d = torch::tensor({8.0f, 8.0f, 8.0f, 8.0f}).view({2, 2});
  const auto conics = torch::tensor({0.05f, 0.0f, 0.05f, 0.05f, 0.0f, 0.05f}).view({2, 3});
  const auto colors = torch::tensor({1.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f}).view({2, 3});  // red, blue
  const auto opacities = torch::full({2}, 0.99f), radii = torch::full({2}, 14.0f), background = torch::zeros({3}, f32);
  for (const bool red_in_front : {true, false}) {
    const auto depths = red_in_front ? torch::tensor({1.0f, 2.0f}) : torch::tensor({2.0f, 1.0f});
    const auto [image, alpha] = rasterize_gaussians(means2d, conics, colors, opacities, depths, radii, background, 16, 16);
    const auto centre = image[8][8];
    if (red_in_front) {
      EXPECT_GT(centre[0].item<float>(), 0.98f);
      EXPECT_LT(centre[2].item<float>(), 0.011f);
    } else {
      EXPECT_GT(centre[2].item<float>(), 0.98f);
      EXPECT_LT(centre[0].item<float>(), 0.011f);
    }
  }
}

TEST(GaussianRasterization, EachTileListsTheGaussiansReachingItFrontToBack) {
  // The forward's tile lists against the rule the header states: a Gaussian
  // is listed in every 16 x 16 tile holding a pixel centre within its radius
  // of its mean (clamped to the picture), each list in depth order with ties
  // in the Gaussians' order; a Gaussian not drawn (radius 0, a NaN depth or
  // mean) is in no list.
  torch::manual_seed(6);
  auto scene = random_scene(300, 70, 50, 1.0, torch::kFloat32);
  scene.depths = torch::randint(0, 20, {300}).to(torch::kFloat32);  // many ties
  const float nan = std::numeric_limits<float>::quiet_NaN();
  scene.radii[3] = 0;
  scene.depths[3] = nan;
  scene.means2d[7][0] = nan;
  using Forward = std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor>(
      const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&,
      const torch::Tensor&, const torch::Tensor&, int64_t, int64_t);
  const auto forward = fskin_operator<Forward>("fskin::_rasterize_gaussians_forward");
  const auto [image, alpha, listed, ranges] = forward.call(scene.means2d, scene.conics, scene.colors, scene.opacities,
                                                           scene.depths, scene.radii, scene.background, 70, 50);
  const int64_t tiles_x = 5, tiles_y = 4;  // ceil(70 / 16), ceil(50 / 16)
  ASSERT_EQ(ranges.numel(), tiles_x * tiles_y + 1);
  const auto m = scene.means2d.accessor<float, 2>();
  const auto r = scene.radii.accessor<float, 1>(), d = scene.depths.accessor<float, 1>();
  const auto first = [](float low, int64_t tiles) {
    return std::clamp<int64_t>(static_cast<int64_t>(std::floor(low / 16)), 0, tiles);
  };
  const auto end = [](float high, int64_t tiles) {
    return std::clamp<int64_t>(static_cast<int64_t>(std::floor(high / 16)) + 1, 0, tiles);
  };
  for (int64_t ty = 0; ty < tiles_y; ++ty) {
    for (int64_t tx = 0; tx < tiles_x; ++tx) {
      std::vector<int64_t> expected;
      for (int64_t g = 0; g < 300; ++g) {
        if (!(r[g] > 0) || !std::isfinite(m[g][0]) || !std::isfinite(m[g][1])) continue;
        if (tx >= first(m[g][0] - r[g], tiles_x) && tx < end(m[g][0] + r[g], tiles_x) &&
            ty >= first(m[g][1] - r[g], tiles_y) && ty < end(m[g][1] + r[g], tiles_y))
          expected.push_back(g);
      }
      std::stable_sort(expected.begin(), expected.end(), [&](int64_t a, int64_t b) { return d[a] < d[b]; });
      const int64_t t = ty * tiles_x + tx;
      const auto got = listed.slice(0, ranges[t].item<int64_t>(), ranges[t + 1].item<int64_t>());
      EXPECT_TRUE(torch::equal(got, torch::tensor(expected, torch::kInt64))) << "tile " << tx << ", " << ty;
    }
  }
}

TEST(GaussianRasterization, GradientsRepeatExactlyAcrossRunsAndThreadCounts) {
  torch::manual_seed(5);
  const auto scene = random_scene(400, 70, 50, 1.0, torch::kFloat32);
  const auto grad_image = torch::randn({50, 70, 3}), grad_alpha = torch::randn({50, 70});
  const int threads = at::get_num_threads();
  at::set_num_threads(1);
  const auto one = render_with_gradients(&rasterize_gaussians, scene, grad_image, grad_alpha);
  at::set_num_threads(2);
  const auto two = render_with_gradients(&rasterize_gaussians, scene, grad_image, grad_alpha);
  const auto again = render_with_gradients(&rasterize_gaussians, scene, grad_image, grad_alpha);
  at::set_num_threads(threads);
  EXPECT_TRUE(torch::equal(one.image, two.image));
  for (size_t i = 0; i < one.grads.size(); ++i) {
    EXPECT_TRUE(torch::equal(one.grads[i], two.grads[i])) << i;
    EXPECT_TRUE(torch::equal(two.grads[i], again.grads[i])) << i;
  }
}

TEST(GaussianRasterization, NoGaussiansOrNonFiniteOnesGiveTheBackground) {
  const auto empty2 = torch::zeros({0, 2}), empty3 = torch::zeros({0, 3}), empty = torch::zeros({0});
  const auto background = torch::tensor({0.1f, 0.2f, 0.3f});
  const auto [image, alpha] = rasterize_gaussians(empty2, empty3, empty3, empty, empty, empty, background, 5, 3);
  EXPECT_TRUE(torch::allclose(image, background.expand({3, 5, 3})));
  EXPECT_EQ(alpha.abs().max().item<float>(), 0.0f);
  // Non-finite Gaussians draw nothing: a NaN mean, opacity or conic, an infinite radius.
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const auto means2d = torch::tensor({nan, 2.0f, 2.0f, 1.0f, 2.0f, 1.0f, 2.0f, 1.0f}).view({4, 2});
  auto conics = torch::full({4, 3}, 0.5f);
  conics[2][0] = nan;
  const auto opacities = torch::tensor({0.9f, nan, 0.9f, 0.9f}), radii = torch::tensor({3.0f, 3.0f, 3.0f, inf});
  const auto [bad_image, bad_alpha] =
      rasterize_gaussians(means2d, conics, torch::ones({4, 3}), opacities, torch::ones({4}), radii, background, 5, 3);
  EXPECT_TRUE(torch::allclose(bad_image, background.expand({3, 5, 3})));
  EXPECT_EQ(bad_alpha.abs().max().item<float>(), 0.0f);
}

TEST(GaussianRasterization, BadInputsAreErrorsNamingTheArgument) {
  const auto means2d = torch::zeros({2, 2}), conics = torch::ones({2, 3}), colors = torch::ones({2, 3});
  const auto opacities = torch::ones({2}), depths = torch::ones({2}), radii = torch::ones({2});
  const auto background = torch::zeros({3});
  testing::expect_error(
      [&] { rasterize_gaussians(means2d, torch::ones({2, 2}), colors, opacities, depths, radii, background, 8, 8); },
      {"conics", "[2, 2]"});
  testing::expect_error(
      [&] {
        rasterize_gaussians(means2d, conics, torch::ones({2, 17}), opacities, depths, radii, torch::zeros({17}), 8, 8);
      },
      {"1 to 16 channels", "17"});
  testing::expect_error(
      [&] { rasterize_gaussians(means2d, conics, colors, opacities, depths, radii, background, 0, 8); },
      {"pixels a side", "0 x 8"});
  testing::expect_error(
      [&] {
        rasterize_gaussians(means2d, conics, colors.to(torch::kFloat64), opacities, depths, radii, background, 8, 8);
      },
      {"share one dtype"});
  testing::expect_error(
      [&] { rasterize_gaussians(means2d, conics, colors, opacities, depths, radii, torch::zeros({4}), 8, 8); },
      {"background"});
}

}  // namespace
}  // namespace fskin
