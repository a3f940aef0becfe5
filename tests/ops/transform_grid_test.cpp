// The transform-grid helpers every op shares, called directly on plain arrays.
#include "ops/common/transform_grid.h"

#include <gtest/gtest.h>

#include <vector>

namespace fskin::kernels {
namespace {

// A W x H x D grid (x, y, z) whose 12 channels are an affine function of the
// voxel position: trilinear interpolation must reproduce it exactly.
struct AffineGrid {
  std::vector<double> data;
  GridView<double> view;
  AffineGrid(int w, int h, int d) : data(static_cast<size_t>(w) * h * d * kChannels) {
    for (int z = 0; z < d; ++z)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < kChannels; ++c)
            data[((static_cast<size_t>(z) * h + y) * w + x) * kChannels + c] = value(c, x, y, z);
    view = {data.data(), {w, h, d}, {1.0, 1.0, 1.0}, {0.0, 0.0, 0.0}};
  }
  static double value(int c, double x, double y, double z) { return 0.5 * c + 0.25 * x - 0.125 * y + 0.0625 * c * z; }
};

TEST(TransformGrid, TrilinearReproducesAffineFieldsAndClampsOutside) {
  const AffineGrid g(4, 3, 5);
  const double p[3] = {1.3, 0.7, 3.9};
  double out[kChannels];
  EXPECT_TRUE(trilinear_fetch(g.view, p, out));
  for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(out[c], AffineGrid::value(c, 1.3, 0.7, 3.9), 1e-12);
  const double outside[3] = {-0.5, 1.0, 10.0};
  EXPECT_FALSE(trilinear_fetch(g.view, outside, out));
  for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(out[c], AffineGrid::value(c, 0.0, 1.0, 4.0), 1e-12);
}

TEST(TransformGrid, Invert3x3) {
  const double m[9] = {2, 1, 0, 0, 3, 1, 1, 0, 4};
  double inv[9];
  ASSERT_TRUE(invert3x3(m, 3, inv));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += m[3 * r + k] * inv[3 * k + c];
      EXPECT_NEAR(s, r == c ? 1.0 : 0.0, 1e-12);
    }
  const double singular[9] = {1, 2, 3, 2, 4, 6, 0, 1, 1};
  EXPECT_FALSE(invert3x3(singular, 3, inv));
}

}  // namespace
}  // namespace fskin::kernels
