// The Broyden solver's per-lane math, called directly on plain arrays.
#include "ops/broyden_search/broyden_core.h"

#include <gtest/gtest.h>

#include <vector>

namespace fskin::broyden {
namespace {

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
  kernels::apply_affine(a, x_true, xp);
  double x[3] = {0, 0, 0}, jinv[9];
  const SearchParams<double> params{10, 1e-20, 1e6, 0.0, true};
  const SolveResult r = solve(g, xp, x, jinv, params);
  EXPECT_TRUE(r.valid);
  EXPECT_EQ(r.iterations, 1);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(x[k], x_true[k], 1e-12);
}

// The solver's step and update from a deliberately wrong Jacobian still
// converge on a linear map, as SNARF's lanes drive them.
TEST(BroydenCore, StepAndAbsorbConvergeFromAPerturbedJacobian) {
  const double a[9] = {1.5, 0.2, 0.1, -0.3, 0.8, 0.2, 0.1, 0.1, 1.2};
  const double target[3] = {0.3, -0.4, 0.9};
  double x[3] = {0, 0, 0}, jinv[9] = {0.6, 0, 0, 0, 1.1, 0, 0, 0, 0.9};  // rough diagonal guess
  double g[3], dx[3];
  auto eval = [&](const double* p, double* out) {
    for (int r = 0; r < 3; ++r) out[r] = a[3 * r] * p[0] + a[3 * r + 1] * p[1] + a[3 * r + 2] * p[2] - target[r];
  };
  eval(x, g);
  const SearchParams<double> params{30, 1e-24, 1e6, 0.0, false};
  LaneState state = LaneState::Active;
  int k = 0;
  for (; (state = broyden_step(x, jinv, g, dx, k, params)) == LaneState::Active; ++k) {
    double gn[3];
    eval(x, gn);
    broyden_absorb(jinv, g, dx, gn, 0.0);
  }
  EXPECT_EQ(state, LaneState::Converged);
  EXPECT_LT(k, 30);
  EXPECT_LT(g[0] * g[0] + g[1] * g[1] + g[2] * g[2], 1e-24);
  // Out of iterations: failed, with the iteration it stopped at.
  double y[3] = {0, 0, 0}, j2[9] = {0.6, 0, 0, 0, 1.1, 0, 0, 0, 0.9}, g2[3];
  eval(y, g2);
  const SearchParams<double> none{0, 1e-24, 1e6, 0.0, false};
  EXPECT_EQ(broyden_step(y, j2, g2, dx, 0, none), LaneState::Failed);
}

}  // namespace
}  // namespace fskin::broyden
