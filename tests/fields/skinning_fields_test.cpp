#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/geometry/voxel_box.h"
#include "fskin/fields/mlp_skinning_field.h"
#include "fskin/fields/preset_skinning_field.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "test_util.h"

namespace fskin {
namespace {

VoxelBox unit_box(GridShape shape) {
  VoxelBox box;
  box.shape = shape;
  return box;  // [-1, 1]^3
}

TEST(VoxelBox, AroundMapsTheBoundingBoxInside) {
  const auto pts = torch::tensor({{0.0, 0.0, 0.0}, {1.0, 2.0, 0.2}, {-1.0, 1.0, -0.2}});  // flat in z
  const auto box = VoxelBox::around(pts, GridShape{16, 64, 64}, 1.2, 4.0);
  const auto u = box.to_grid(pts);
  EXPECT_LT(u.abs().max().item<double>(), 1.0);
  EXPECT_NEAR(box.to_grid(torch::tensor({{0.0, 2.0, 0.0}}))[0][1].item<double>(), 1.0 / 1.2, 1e-6);
  EXPECT_NEAR(box.scale[2], 4 * box.scale[0], 1e-12);
  EXPECT_TRUE(box.contains(pts).all().item<bool>());
  EXPECT_THROW(VoxelBox::around(torch::zeros({3, 3})), Error);
}

TEST(VoxelBox, VoxelCentresSpanTheBoxCorners) {
  VoxelBox box = unit_box(GridShape{3, 4, 5});
  box.offset = {0.5, 0.0, 0.0};
  const auto c = box.voxel_centres(torch::kFloat64);
  EXPECT_EQ(c.sizes(), (std::vector<int64_t>{3, 4, 5, 3}));
  EXPECT_TRUE(torch::allclose(c[0][0][0], torch::tensor({-1.5, -1.0, -1.0}, torch::kFloat64)));
  EXPECT_TRUE(torch::allclose(c[2][3][4], torch::tensor({0.5, 1.0, 1.0}, torch::kFloat64)));
  EXPECT_TRUE(torch::allclose(box.to_grid(c)[1][2][3], torch::tensor({0.5, 1.0 / 3.0, 0.0}, torch::kFloat64)));
}

TEST(SampleGrid, ReproducesVoxelsAndAffineFunctions) {
  const VoxelBox box = unit_box(GridShape{4, 5, 6});
  const auto c = box.voxel_centres(torch::kFloat64);
  // An affine function of position is reproduced exactly by trilinear interpolation.
  const auto grid = torch::stack({c.select(-1, 0) * 2 + c.select(-1, 2), c.select(-1, 1) - 1}, -1);
  const auto p = torch::rand({50, 3}, torch::kFloat64) * 2 - 1;
  const auto v = sample_voxels(grid, box, p);
  EXPECT_TRUE(torch::allclose(v.select(1, 0), p.select(1, 0) * 2 + p.select(1, 2), 1e-10, 1e-10));
  EXPECT_TRUE(torch::allclose(v.select(1, 1), p.select(1, 1) - 1, 1e-10, 1e-10));
  EXPECT_THROW(sample_voxels(grid.narrow(0, 0, 2), box, p), Error);
}

TEST(SkinningFields, MlpWeightsAreADistribution) {
  MlpSkinningFieldOptions o;
  o.num_bones = 5;
  MlpSkinningField field(o);
  const auto w = field.weights(torch::randn({2, 7, 3}));
  EXPECT_EQ(w.sizes(), (std::vector<int64_t>{2, 7, 5}));
  EXPECT_TRUE(torch::allclose(w.sum(-1), torch::ones({2, 7}), 1e-5, 1e-5));
  EXPECT_TRUE((w >= 0).all().item<bool>());
}

TEST(SkinningFields, DistilledGridPassesGradientsToTheMlp) {
  MlpSkinningFieldOptions o;
  o.num_bones = 4;
  o.hidden_dim = 16;
  auto mlp = std::make_shared<MlpSkinningField>(o);
  DistilledSkinningField field(mlp, unit_box(GridShape{4, 6, 6}));
  const auto p = torch::rand({10, 3}) * 2 - 1;
  field.weights(p).select(1, 0).sum().backward();
  for (const auto& param : mlp->parameters()) {
    ASSERT_TRUE(param.grad().defined());
  }
  EXPECT_GT(mlp->parameters().back().grad().abs().sum().item<double>(), 0);
  // At voxel centres the grid equals the MLP; freeze() keeps those values.
  const auto centres = field.box().voxel_centres().reshape({-1, 3});
  torch::NoGradGuard no_grad;
  EXPECT_TRUE(torch::allclose(field.weights(centres), mlp->weights(centres), 1e-5, 1e-5));
  const auto frozen = field.freeze();
  EXPECT_TRUE(torch::allclose(frozen->weights(p), field.weights(p), 1e-6, 1e-6));
  EXPECT_TRUE(frozen->parameters().empty());
}

TEST(SkinningFields, PresetDiffusionKeepsSurfaceWeightsAndNormalises) {
  // Two vertices with one-hot weights on either side of the box.
  const auto v = torch::tensor({{-0.5, 0.0, 0.0}, {0.5, 0.0, 0.0}});
  const auto w = torch::tensor({{1.0, 0.0}, {0.0, 1.0}});
  const auto field = diffuse_weights_to_grid(v, w, unit_box(GridShape{9, 9, 9}));
  const auto at_vertices = field->weights(v);
  EXPECT_TRUE(torch::allclose(at_vertices, w, 1e-5, 1e-5));
  const auto g = field->grid_weights();
  EXPECT_TRUE(torch::allclose(g.sum(-1), torch::ones({9, 9, 9}), 1e-5, 1e-5));
  // Off the surface, between the two parts, the weights blend.
  const auto mid = field->weights(torch::tensor({{0.0, 0.9, 0.9}}));
  EXPECT_GT(mid[0][0].item<double>(), 0.05);
  EXPECT_GT(mid[0][1].item<double>(), 0.05);
  EXPECT_THROW(diffuse_weights_to_grid(v, w.narrow(0, 0, 1), unit_box(GridShape{9, 9, 9})), Error);
}

TEST(SkinningFields, FrozenGridRejectsBadGrids) {
  EXPECT_THROW(FrozenSkinningField(torch::ones({3, 3, 3, 2}), unit_box(GridShape{4, 4, 4})), Error);
  auto bad = torch::ones({4, 4, 4, 2});
  bad[1][1][1][0] = NAN;
  EXPECT_THROW(FrozenSkinningField(bad, unit_box(GridShape{4, 4, 4})), Error);
  auto negative = torch::full({4, 4, 4, 2}, 0.5);
  negative[3][2][1][1] = -0.25;
  testing::expect_error([&] { FrozenSkinningField(negative, unit_box(GridShape{4, 4, 4})); },
                        {"must be >= 0", "-0.25", "(3, 2, 1), bone 1"});
}

}  // namespace
}  // namespace fskin
