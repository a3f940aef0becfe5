#include "fskin/geometry/voxel_box.h"

#include <gtest/gtest.h>

#include "test_util.h"
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/geometry/character_size.h"

namespace fskin {
namespace {

torch::Tensor box_corners(double x, double y, double z) {
  return torch::tensor({{-x / 2, 0.0, -z / 2}, {x / 2, y, z / 2}}, torch::kFloat64);
}

TEST(VoxelBoxFit, VoxelCountsFollowTheExtentsAlongAnyAxis) {
  // A person in a T-pose: about the papers' demo grid (x and y 32, z thin).
  const auto person = VoxelBox::fit(box_corners(1.7, 1.7, 0.3), 32);
  EXPECT_EQ(person.shape.width, 32);
  EXPECT_EQ(person.shape.height, 32);
  EXPECT_GE(person.shape.depth, 8);
  EXPECT_LE(person.shape.depth, 12);
  // The same long body along x, y or z: the same counts, permuted.
  const auto along_x = VoxelBox::fit(box_corners(2.0, 0.5, 0.3), 32);
  const auto along_z = VoxelBox::fit(box_corners(0.3, 0.5, 2.0), 32);
  EXPECT_EQ(along_x.shape.width, 32);
  EXPECT_EQ(along_z.shape.depth, 32);
  EXPECT_EQ(along_x.shape.depth, along_z.shape.width);
  EXPECT_EQ(along_x.shape.height, along_z.shape.height);
  for (const auto& [box, corners] : {std::pair{along_x, box_corners(2.0, 0.5, 0.3)}, {along_z, box_corners(0.3, 0.5, 2.0)}})
    EXPECT_TRUE(box.contains(corners).all().item<bool>());
  // Padding: 5 % of the longest side on every side, so a point 0.09 m beyond
  // a 2 m body's thin side is still inside, and one 0.11 m beyond is not.
  EXPECT_TRUE(along_x.contains(torch::tensor({{0.0, 0.0, 0.15 + 0.09}}, torch::kFloat64)).all().item<bool>());
  EXPECT_FALSE(along_x.contains(torch::tensor({{0.0, 0.0, 0.15 + 0.11}}, torch::kFloat64)).all().item<bool>());
  // Coarse grids keep at least 1.25 voxels beyond the body.
  const auto coarse = VoxelBox::fit(box_corners(2.0, 0.5, 0.3), 8);
  const double spacing = 2 / coarse.scale[0] / (coarse.shape.width - 1);
  EXPECT_NEAR(1 / coarse.scale[0] - 1.0, 1.25 * spacing, 1e-9);
  // Voxels are near cubes: spacing along every axis within one voxel of the longest's.
  for (const auto& box : {person, along_x, along_z}) {
    const double spacing_x = 2 / box.scale[0] / (box.shape.width - 1);
    const double spacing_z = 2 / box.scale[2] / (box.shape.depth - 1);
    EXPECT_LT(std::abs(spacing_x - spacing_z) / std::max(spacing_x, spacing_z), 0.25);
  }
}

TEST(VoxelBoxFit, ScalingThePointsScalesTheBoxOnly) {
  const auto unit = VoxelBox::fit(box_corners(1.0, 0.4, 0.6), 24);
  for (double s : {0.01, 30.0}) {
    const auto scaled = VoxelBox::fit(box_corners(1.0, 0.4, 0.6) * s, 24);
    EXPECT_EQ(scaled.shape.voxels(), unit.shape.voxels());
    EXPECT_EQ(scaled.shape.depth, unit.shape.depth);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(scaled.scale[a] * s, unit.scale[a], 1e-9 * unit.scale[a]);
  }
}

TEST(VoxelBoxFit, BadInputIsAnError) {
  EXPECT_THROW(VoxelBox::fit(torch::zeros({2, 3}), 32), Error);
  EXPECT_THROW(VoxelBox::fit(torch::zeros({0, 3}), 32), Error);
  EXPECT_THROW(VoxelBox::fit(box_corners(1, 1, 1), 1), Error);
  // More voxels than any grid may hold: an error up front, not a petabyte allocation later.
  testing::expect_error([] { VoxelBox::fit(box_corners(1, 1, 1), 100000); }, {"longest_voxels (100000)", "1024"});
  EXPECT_NO_THROW(VoxelBox::fit(box_corners(1, 1, 1), 1024));
  testing::expect_error([] { VoxelBox::around(box_corners(1, 1, 1), GridShape{8, 2048, 8}); },
                        {"2048", "at most 1024"});
}

TEST(CharacterSize, IsTheLongestSide) {
  EXPECT_DOUBLE_EQ(character_size(box_corners(0.2, 3.0, 0.5)), 3.0);
  EXPECT_DOUBLE_EQ(length_unit(box_corners(0.2, 3.4, 0.5)), 2.0);
  EXPECT_THROW(character_size(torch::ones({4, 3})), Error);
}

}  // namespace
}  // namespace fskin
