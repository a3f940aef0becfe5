// The kernel math called directly on plain arrays.
#include "ops/broyden_search/broyden_core.h"

#include <gtest/gtest.h>

#include <vector>

namespace fskin::broyden {
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

TEST(BroydenCore, TrilinearReproducesAffineFieldsAndClampsOutside) {
  const AffineGrid g(4, 3, 5);
  const double p[3] = {1.3, 0.7, 3.9};
  double out[kChannels];
  EXPECT_TRUE(trilinear_fetch(g.view, p, out));
  for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(out[c], AffineGrid::value(c, 1.3, 0.7, 3.9), 1e-12);
  const double outside[3] = {-0.5, 1.0, 10.0};
  EXPECT_FALSE(trilinear_fetch(g.view, outside, out));
  for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(out[c], AffineGrid::value(c, 0.0, 1.0, 4.0), 1e-12);
}

TEST(BroydenCore, Invert3x3) {
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

TEST(BroydenCore, BroydenUpdateSatisfiesSecantEquation) {
  double jinv[9] = {1, 0.1, 0, 0, 1, 0.2, 0.3, 0, 1};
  const double dx[3] = {0.1, -0.2, 0.05}, dg[3] = {0.3, 0.1, -0.2};
  broyden_update(jinv, dx, dg, 0.0);
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(jinv[3 * r] * dg[0] + jinv[3 * r + 1] * dg[1] + jinv[3 * r + 2] * dg[2], dx[r], 1e-12);
}

// A grid holding one constant affine map A x + t: solve() must find
// x = A^-1 (x' - t), in one step since the initial inverse Jacobian is exact.
TEST(BroydenCore, SolvesKnownAffineMap) {
  const double a[kChannels] = {1.2, 0.3, 0.0, 0.5, -0.2, 0.9, 0.1, -1.0, 0.0, 0.4, 1.1, 2.0};
  std::vector<double> data(2 * 2 * 2 * kChannels);
  for (size_t i = 0; i < data.size(); ++i) data[i] = a[i % kChannels];
  // Box [-10, 10]^3 -> voxel coordinates [0, 1].
  const GridView<double> g{data.data(), {2, 2, 2}, {0.05, 0.05, 0.05}, {0.5, 0.5, 0.5}};
  const double x_true[3] = {0.7, -1.3, 2.2};
  double xp[3];
  apply_affine(a, x_true, xp);
  double x[3] = {0, 0, 0}, jinv[9];
  const SearchParams<double> params{10, 1e-20, 1e6, 0.0};
  const SolveResult r = solve(g, xp, x, jinv, params);
  EXPECT_TRUE(r.valid);
  EXPECT_EQ(r.iterations, 1);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(x[k], x_true[k], 1e-12);
}

// Broyden from a deliberately wrong Jacobian still converges on a linear map.
TEST(BroydenCore, BroydenConvergesFromPerturbedJacobian) {
  const double a[9] = {1.5, 0.2, 0.1, -0.3, 0.8, 0.2, 0.1, 0.1, 1.2};
  const double target[3] = {0.3, -0.4, 0.9};
  double x[3] = {0, 0, 0}, jinv[9] = {0.6, 0, 0, 0, 1.1, 0, 0, 0, 0.9};  // rough diagonal guess
  double g[3];
  auto eval = [&](const double* p, double* out) {
    for (int r = 0; r < 3; ++r) out[r] = a[3 * r] * p[0] + a[3 * r + 1] * p[1] + a[3 * r + 2] * p[2] - target[r];
  };
  eval(x, g);
  int k = 0;
  for (; k < 30 && g[0] * g[0] + g[1] * g[1] + g[2] * g[2] > 1e-24; ++k) {
    double dx[3], gn[3], dg[3];
    for (int r = 0; r < 3; ++r) dx[r] = -(jinv[3 * r] * g[0] + jinv[3 * r + 1] * g[1] + jinv[3 * r + 2] * g[2]);
    for (int r = 0; r < 3; ++r) x[r] += dx[r];
    eval(x, gn);
    for (int r = 0; r < 3; ++r) { dg[r] = gn[r] - g[r]; g[r] = gn[r]; }
    broyden_update(jinv, dx, dg, 0.0);
  }
  EXPECT_LT(k, 30);
  EXPECT_LT(g[0] * g[0] + g[1] * g[1] + g[2] * g[2], 1e-24);
}

TEST(BroydenCore, DropsDuplicateRootsKeepingTheFirst) {
  const double x[12] = {0, 0, 0, 1, 1, 1, 0, 0, 5e-5, 1, 1, 1.5};
  bool valid[4] = {false, true, true, true};
  drop_duplicate_roots(x, valid, 4, 1e-8);  // invalid 0 does not absorb 2
  EXPECT_TRUE(valid[1]);
  EXPECT_TRUE(valid[2]);
  EXPECT_TRUE(valid[3]);
  bool valid2[4] = {true, true, true, true};
  drop_duplicate_roots(x, valid2, 4, 1e-8);
  EXPECT_TRUE(valid2[0]);
  EXPECT_TRUE(valid2[1]);
  EXPECT_FALSE(valid2[2]);
  EXPECT_TRUE(valid2[3]);
}

}  // namespace
}  // namespace fskin::broyden
