// The rasteriser's CPU tile kernel (Gaussian by Gaussian over each tile, only
// where a Gaussian can count) against the per-pixel core the CUDA kernel runs,
// both called directly on plain arrays: the same image, alpha and per-entry
// gradient rows to the last bit, forward and backward, with pixels that stop
// early, Gaussians whose opacity is above 1 or whose conic is not positive
// definite (no reach bound: every pixel tested), and faint ones (none counts).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "ops/gaussian_rasterization/gaussian_rasterization_kernel.h"

namespace fskin::gaussian_rasterization {
namespace {

struct PlainScene {
  int width = 0, height = 0, tiles_x = 0, tiles_y = 0, channels = 3;
  std::vector<double> means2d, conics, colors, opacities, background;
  std::vector<int64_t> tile_gaussians, tile_ranges;
  std::vector<double> image, alpha, grad_image, grad_alpha;

  RasterLaunch<double> launch() {
    RasterLaunch<double> a{};
    a.means2d = means2d.data();
    a.conics = conics.data();
    a.colors = colors.data();
    a.opacities = opacities.data();
    a.background = background.data();
    a.tile_gaussians = tile_gaussians.data();
    a.tile_ranges = tile_ranges.data();
    a.gaussians = static_cast<int64_t>(opacities.size());
    a.channels = channels;
    a.width = width;
    a.height = height;
    a.tiles_x = tiles_x;
    a.tiles_y = tiles_y;
    a.image = image.data();
    a.alpha = alpha.data();
    a.grad_image = grad_image.data();
    a.grad_alpha = grad_alpha.data();
    return a;
  }
};

// n Gaussians 1-8 pixels wide over a width x height picture; every tile lists
// every Gaussian in one shared random depth order (the kernels take any list).
PlainScene make_scene(int n, int width, int height, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  PlainScene s;
  s.width = width;
  s.height = height;
  s.tiles_x = (width + kTileSize - 1) / kTileSize;
  s.tiles_y = (height + kTileSize - 1) / kTileSize;
  for (int i = 0; i < n; ++i) {
    s.means2d.push_back(unit(rng) * (width + 8) - 4);
    s.means2d.push_back(unit(rng) * (height + 8) - 4);
    const double angle = unit(rng) * M_PI, s1 = 1 + 7 * unit(rng), s2 = 1 + 7 * unit(rng);
    const double c = std::cos(angle), sn = std::sin(angle);
    const double xx = c * c * s1 * s1 + sn * sn * s2 * s2, xy = c * sn * (s1 * s1 - s2 * s2),
                 yy = sn * sn * s1 * s1 + c * c * s2 * s2, det = xx * yy - xy * xy;
    s.conics.insert(s.conics.end(), {yy / det, -xy / det, xx / det});
    for (int k = 0; k < s.channels; ++k) s.colors.push_back(unit(rng));
    s.opacities.push_back(0.02 + 0.97 * unit(rng));
  }
  // The cases without a reach bound, and a faint one.
  s.opacities[0] = 1.5;
  s.conics[3 * 1 + 1] = 10 * s.conics[3 * 1 + 0];  // b^2 > a c: not positive definite
  s.opacities[2] = 0.002;
  s.background = {0.2, 0.5, 0.9};
  std::vector<int64_t> order(n);
  std::iota(order.begin(), order.end(), int64_t{0});
  std::shuffle(order.begin(), order.end(), rng);
  s.tile_ranges.push_back(0);
  for (int t = 0; t < s.tiles_x * s.tiles_y; ++t) {
    s.tile_gaussians.insert(s.tile_gaussians.end(), order.begin(), order.end());
    s.tile_ranges.push_back(static_cast<int64_t>(s.tile_gaussians.size()));
  }
  const size_t pixels = static_cast<size_t>(width) * height;
  s.image.assign(pixels * s.channels, 0.0);
  s.alpha.assign(pixels, 0.0);
  for (size_t i = 0; i < pixels * s.channels; ++i) s.grad_image.push_back(unit(rng) - 0.5);
  for (size_t i = 0; i < pixels; ++i) s.grad_alpha.push_back(unit(rng) - 0.5);
  return s;
}

template <typename PerPixel>
void for_each_pixel(const PlainScene& s, PerPixel&& per_pixel) {
  for (int y = 0; y < s.height; ++y) {
    for (int x = 0; x < s.width; ++x) {
      const int64_t tile = static_cast<int64_t>(y / kTileSize) * s.tiles_x + x / kTileSize;
      per_pixel(s.tile_ranges[tile], s.tile_ranges[tile + 1], x, y);
    }
  }
}

TEST(GaussianRasterizationCore, TheTileKernelMatchesThePerPixelCoreToTheLastBit) {
  // 37 x 21: edge tiles narrower than 16; 150 Gaussians: many pixels stop early.
  PlainScene s = make_scene(150, 37, 21, 3);
  auto a = s.launch();
  rasterize_cpu(a, false);
  const auto tile_image = s.image, tile_alpha = s.alpha;
  for_each_pixel(s, [&](int64_t begin, int64_t end, int x, int y) { rasterize_pixel(a, begin, end, x, y); });
  EXPECT_EQ(tile_image, s.image);
  EXPECT_EQ(tile_alpha, s.alpha);
  int opaque = 0;
  for (const double v : s.alpha) opaque += v > 0.9999 - 1e-6 ? 1 : 0;
  EXPECT_GT(opaque, 0) << "no pixel stopped early: the scene does not test the stop";

  const int columns = gradient_columns(s.channels);
  const size_t pixels = static_cast<size_t>(s.width) * s.height;
  std::vector<double> tile_rows(s.tile_gaussians.size() * columns, 0.0), pixel_rows = tile_rows;
  std::vector<double> tile_background(pixels * s.channels, 0.0), pixel_background = tile_background;
  a.grad_rows = tile_rows.data();
  a.grad_background = tile_background.data();
  rasterize_cpu(a, true);
  a.grad_rows = pixel_rows.data();
  a.grad_background = pixel_background.data();
  for_each_pixel(s, [&](int64_t begin, int64_t end, int x, int y) {
    rasterize_pixel_backward(a, begin, end, x, y, [&](int64_t entry, int64_t, int column, double value) {
      pixel_rows[entry * columns + column] += value;
    });
  });
  EXPECT_EQ(tile_rows, pixel_rows);
  EXPECT_EQ(tile_background, pixel_background);
  const double largest = *std::max_element(tile_rows.begin(), tile_rows.end(),
                                           [](double l, double r) { return std::abs(l) < std::abs(r); });
  EXPECT_GT(std::abs(largest), 1e-3) << "the gradients are all zero: nothing was compared";
}

TEST(GaussianRasterizationCore, ReachBoxesHoldEveryPixelThatCounts) {
  PlainScene s = make_scene(60, 48, 48, 11);
  const auto a = s.launch();
  for (int64_t g = 0; g < a.gaussians; ++g) {
    double half_x = 0, half_y = 0;
    const bool bounded = footprint_reach(a, g, half_x, half_y);
    if (g == 0 || g == 1) {
      EXPECT_FALSE(bounded) << "Gaussian " << g;
      continue;
    }
    ASSERT_TRUE(bounded) << "Gaussian " << g;
    for (int y = -8; y < s.height + 8; ++y) {
      for (int x = -8; x < s.width + 8; ++x) {
        if (!footprint(a, g, double(x), double(y)).counts) continue;
        EXPECT_LE(std::abs(x - a.means2d[2 * g]), half_x) << "Gaussian " << g << " pixel " << x << "," << y;
        EXPECT_LE(std::abs(y - a.means2d[2 * g + 1]), half_y) << "Gaussian " << g << " pixel " << x << "," << y;
      }
    }
  }
  double half_x = 0, half_y = 0;
  ASSERT_TRUE(footprint_reach(a, 2, half_x, half_y));
  EXPECT_LT(half_x, 0) << "opacity 0.002 < 1/255 counts nowhere";
}

}  // namespace
}  // namespace fskin::gaussian_rasterization
