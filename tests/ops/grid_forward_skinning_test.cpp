#include "fskin/ops/grid_forward_skinning.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "ops/grid_forward_skinning/grid_forward_skinning_kernel.h"

namespace fskin {
namespace {

VoxelBox skewed_box() {
  VoxelBox box;
  box.shape = GridShape{3, 5, 4};
  box.offset = {0.1, -0.2, 0.05};
  box.scale = {1.5, 0.8, 2.0};
  return box;
}

// The differentiable LibTorch path the kernel replaces: sample_voxels, then the 3x4 matrix.
torch::Tensor reference(const torch::Tensor& grid, const VoxelBox& box, const torch::Tensor& x) {
  const auto t = sample_voxels(grid, box, x).reshape({x.size(0), x.size(1), 3, 4});
  return torch::matmul(t.narrow(3, 0, 3), x.unsqueeze(-1)).squeeze(-1) + t.select(3, 3);
}

TEST(GridForwardSkinning, EqualsSampledTransformsInsideAndOutsideTheBox) {
  torch::manual_seed(3);
  const auto box = skewed_box();
  const auto grid = torch::randn({2, 3, 5, 4, 12}, torch::kFloat64);
  // Grid coordinates up to 1.5: a third of the points lie outside (border clamping).
  const auto u = torch::rand({2, 300, 3}, torch::kFloat64) * 3 - 1.5;
  const auto scale = torch::tensor({1.5, 0.8, 2.0}, torch::kFloat64);
  const auto offset = torch::tensor({0.1, -0.2, 0.05}, torch::kFloat64);
  const auto x = u / scale - offset;
  const auto expected = reference(grid, box, x);
  EXPECT_TRUE(torch::allclose(grid_forward_skinning(grid, box, x), expected, 1e-12, 1e-12));
  const auto single = grid_forward_skinning(grid.to(torch::kFloat32), box, x.to(torch::kFloat32));
  EXPECT_EQ(single.scalar_type(), torch::kFloat32);
  EXPECT_TRUE(torch::allclose(single.to(torch::kFloat64), expected, 1e-5, 1e-5));
}

// The plain-pointer body on a hand-made 2 x 2 x 2 grid: every voxel holds the
// identity with a translation of (voxel x index, 0, voxel z index), so a point
// at voxel fractions (fx, fy, fz) moves by (fx, 0, fz).
TEST(GridForwardSkinning, CoreInterpolatesTranslationsLinearly) {
  double grid[2][2][2][12] = {};
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) {
        double* m = grid[z][y][x];
        m[0] = m[5] = m[10] = 1.0;
        m[3] = x;
        m[11] = z;
      }
  grid_skinning::SkinningLaunch<double> a{};
  a.grid.data = &grid[0][0][0][0];
  for (int k = 0; k < 3; ++k) {
    a.grid.size[k] = 2;
    a.grid.scale[k] = 1.0;  // voxel coordinates = point coordinates
    a.grid.shift[k] = 0.0;
  }
  const double points[2][3] = {{0.25, 0.5, 0.75}, {3.0, -1.0, 0.5}};  // the second clamps to x = 1, y = 0
  double out[2][3];
  a.x = &points[0][0];
  a.batch = 1;
  a.points = 2;
  a.out = &out[0][0];
  grid_skinning::skin_point(a, 0);
  grid_skinning::skin_point(a, 1);
  EXPECT_DOUBLE_EQ(out[0][0], 0.5);
  EXPECT_DOUBLE_EQ(out[0][1], 0.5);
  EXPECT_DOUBLE_EQ(out[0][2], 1.5);
  EXPECT_DOUBLE_EQ(out[1][0], 4.0);
  EXPECT_DOUBLE_EQ(out[1][1], -1.0);
  EXPECT_DOUBLE_EQ(out[1][2], 1.0);
}

TEST(GridForwardSkinning, RejectsBadInput) {
  const auto box = skewed_box();
  const auto grid = torch::zeros({1, 3, 5, 4, 12});
  const auto x = torch::zeros({1, 7, 3});
  EXPECT_NO_THROW(grid_forward_skinning(grid, box, x));
  EXPECT_EQ(grid_forward_skinning(grid, box, torch::zeros({1, 0, 3})).size(1), 0);
  EXPECT_THROW(grid_forward_skinning(grid.narrow(1, 0, 2), box, x), Error);            // grid does not match the box
  EXPECT_THROW(grid_forward_skinning(grid, box, torch::zeros({2, 7, 3})), Error);      // frames differ
  EXPECT_THROW(grid_forward_skinning(grid, box, torch::zeros({1, 7, 4})), Error);      // not 3D points
  EXPECT_THROW(grid_forward_skinning(grid, box, x.to(torch::kFloat64)), Error);        // dtypes differ
  EXPECT_THROW(grid_forward_skinning(grid.to(torch::kInt32), box, x.to(torch::kInt32)), Error);
}

}  // namespace
}  // namespace fskin
