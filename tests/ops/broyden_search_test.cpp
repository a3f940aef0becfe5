#include "fskin/ops/broyden_search.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/ops/filter_duplicate_roots.h"
#include "fskin/ops/implicit_gradient.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {
namespace {

VoxelBox unit_box() {
  VoxelBox box;
  box.shape = GridShape{4, 5, 6};
  return box;
}

// A grid holding one affine transform everywhere: every start converges to
// the single root A^-1 (x' - t).
TEST(BroydenSearch, ConstantTransformGridHasOneRoot) {
  const auto a = torch::tensor({{1.1, 0.2, 0.0, 0.1}, {-0.1, 0.9, 0.1, -0.2}, {0.0, 0.1, 1.2, 0.05}}, torch::kFloat64);
  const auto grid = a.reshape({1, 1, 1, 1, 12}).expand({2, 4, 5, 6, 12}).contiguous();
  const auto x_true = (torch::rand({2, 50, 3}, torch::kFloat64) - 0.5);
  const auto x_posed = torch::matmul(x_true, a.narrow(1, 0, 3).t()) + a.select(1, 3);
  // Starts: identity and a shifted copy.
  auto starts = torch::eye(4, torch::kFloat64).repeat({2, 2, 1, 1});
  starts[0][1][0][3] = 0.3;
  BroydenSearchOptions o;
  o.converge_sq = 1e-24;
  o.diverge_sq = 100;  // the shifted start begins far from the root
  o.return_inverse_jacobian = true;
  const auto r = broyden_search(grid, unit_box(), x_posed, starts, o);
  EXPECT_TRUE(r.valid.all().item<bool>());
  EXPECT_TRUE(torch::allclose(r.x_canonical, x_true.unsqueeze(2).expand({2, 50, 2, 3}), 1e-10, 1e-10));
  EXPECT_TRUE((r.iterations <= 1).all().item<bool>());
  const auto expected_jinv = torch::inverse(a.narrow(1, 0, 3));
  EXPECT_TRUE(torch::allclose(r.inverse_jacobian[1][7][1], expected_jinv, 1e-10, 1e-10));
  // Outside the box: not valid.
  const auto far = broyden_search(grid, unit_box(), x_posed + 10, starts, o);
  EXPECT_FALSE(far.valid.any().item<bool>());
}

TEST(BroydenSearch, AutomaticSelectionPrefersBonesDrivingTheirStart) {
  const auto grid = torch::eye(4).narrow(0, 0, 3).reshape({1, 1, 1, 1, 12}).expand({1, 4, 5, 6, 12}).contiguous();
  const auto starts = torch::eye(4).repeat({1, 3, 1, 1});
  // Bone 2 dominates everywhere, then bone 0, then bone 1.
  const auto weights = torch::tensor({0.3, 0.1, 0.6}).expand({4, 5, 6, 3}).contiguous();
  BroydenSearchOptions o;
  o.num_starts = 2;
  const auto r = broyden_search(grid, unit_box(), torch::zeros({1, 1, 3}), starts, o, weights);
  EXPECT_EQ(r.start_index[0][0][0].item<int64_t>(), 2);
  EXPECT_EQ(r.start_index[0][0][1].item<int64_t>(), 0);
  EXPECT_TRUE(r.valid.all().item<bool>());
  EXPECT_THROW(broyden_search(grid, unit_box(), torch::zeros({1, 1, 3}), starts, o), Error);  // no weights
}

TEST(BroydenSearch, RejectsBadInput) {
  const auto grid = torch::zeros({1, 4, 5, 6, 12});
  const auto starts = torch::eye(4).expand({1, 2, 4, 4});
  const auto x = torch::zeros({1, 3, 3});
  BroydenSearchOptions o;
  EXPECT_THROW(broyden_search(grid.narrow(1, 0, 3), unit_box(), x, starts, o), Error);
  EXPECT_THROW(broyden_search(grid, unit_box(), x.to(torch::kFloat64), starts, o), Error);
  EXPECT_THROW(broyden_search(grid, unit_box(), x, torch::eye(4).expand({1, 0, 4, 4}), o), Error);
  auto nan_starts = starts.clone();
  nan_starts[0][1][0][0] = NAN;
  EXPECT_THROW(broyden_search(grid, unit_box(), x, nan_starts, o), Error);
  o.num_starts = 3;
  EXPECT_THROW(broyden_search(grid, unit_box(), x, starts, o), Error);
  // A zero grid has singular transforms: the search ends quickly, nothing valid.
  o.num_starts = -1;
  const auto r = broyden_search(grid, unit_box(), torch::ones({1, 3, 3}), starts, o);
  EXPECT_FALSE(r.valid.any().item<bool>());
}

TEST(FilterDuplicateRoots, DropsLaterCopies) {
  auto x = torch::zeros({1, 2, 3, 3});
  x[0][0][1] = torch::tensor({0.0, 0.0, 5e-5});
  x[0][0][2] = torch::tensor({1.0, 0.0, 0.0});
  x[0][1][2] = torch::tensor({1e-5, 0.0, 0.0});
  auto valid = torch::ones({1, 2, 3}, torch::kBool);
  valid[0][1][0] = false;
  const auto kept = filter_duplicate_roots(x, valid, 1e-4);
  EXPECT_TRUE(torch::equal(kept, torch::tensor({true, false, true, false, true, false}).reshape({1, 2, 3})));
}

TEST(ImplicitGradient, BackwardIsMinusInverseJacobianTransposed) {
  const auto jinv = torch::randn({4, 3, 3}, torch::kFloat64);
  const auto r = torch::randn({4, 3}, torch::kFloat64).requires_grad_(true);
  const auto root = torch::randn({4, 3}, torch::kFloat64);
  const auto x = attach_implicit_gradient(root, jinv, r * 1.0);
  EXPECT_TRUE(torch::equal(x, root));
  const auto g = torch::randn({4, 3}, torch::kFloat64);
  (x * g).sum().backward();
  const auto expected = -torch::matmul(jinv.transpose(1, 2), g.unsqueeze(-1)).squeeze(-1);
  EXPECT_TRUE(torch::allclose(r.grad(), expected));
}

}  // namespace
}  // namespace fskin
