// The surface layer prior: anchors on the mesh, heights against them, and a
// spread that is zero for a common height and whose gradient draws the
// Gaussians toward it.
#include "fskin/gaussians/surface_layer.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <vector>

#include "fskin/skeleton/rotations.h"
#include "test_util.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

GaussianAvatar anchored_avatar(int64_t gaussians) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  GaussianAvatarOptions options;
  options.initial_gaussians = gaussians;
  options.skinning_grid_resolution = 16;
  options.anchored = true;
  return GaussianAvatar(dataset.character(), options, 0);
}

TEST(SurfaceLayer, AnchorsAreTheSamplesAndTheirFacesNormalsAndHeightsStartAtZero) {
  auto avatar = anchored_avatar(200);
  const auto& anchors = avatar->surface_anchors();
  ASSERT_EQ(anchors.sizes(), (std::vector<int64_t>{200, 6}));
  EXPECT_TRUE(torch::equal(anchors.narrow(1, 0, 3), avatar->means().detach()));
  const auto normals = anchors.narrow(1, 3, 3);
  EXPECT_TRUE(torch::allclose(normals.norm(2, 1), torch::ones({200}), 1e-5, 1e-5));
  // The discs start in their faces' planes: their thin local z axis is the anchor's normal.
  const auto rotations = quaternion_to_matrix(avatar->rotations().detach());
  EXPECT_TRUE(torch::allclose(rotations.select(2, 2), normals, 1e-4, 1e-4));
  EXPECT_LT(avatar->anchor_heights().abs().max().item<double>(), 1e-6);
  EXPECT_FALSE(anchors.requires_grad());  // a buffer: no graph to the means
  EXPECT_LT(surface_layer_spread(*avatar).item<double>(), 1e-10);

  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  GaussianAvatarOptions plain;
  plain.initial_gaussians = 10;
  GaussianAvatar unanchored(dataset.character(), plain, 0);
  EXPECT_EQ(unanchored->surface_anchors().sizes(), (std::vector<int64_t>{10, 0}));
  testing::expect_error([&] { unanchored->anchor_heights(); }, {"without anchors"});
}

TEST(SurfaceLayer, TheSpreadIsZeroAtOneCommonHeightAndItsGradientDrawsTheGaussiansToIt) {
  auto avatar = anchored_avatar(100);
  const double spacing = avatar->initial_spacing();
  const auto normals = avatar->surface_anchors().narrow(1, 3, 3);
  {
    torch::NoGradGuard no_grad;
    // All 0.7 spacings below the surface, and slid along it: one common height.
    const auto tangent = torch::cross(normals, torch::tensor({0.3f, 0.5f, 0.8f}).expand_as(normals), 1);
    avatar->means().sub_(0.7 * spacing * normals).add_(0.2 * spacing * tangent);
  }
  EXPECT_LT(surface_layer_spread(*avatar).item<double>(), 1e-8);
  {
    torch::NoGradGuard no_grad;  // half of them one spacing higher: heights -0.7 and +0.3, spread 0.25
    avatar->means().narrow(0, 0, 50).add_(spacing * normals.narrow(0, 0, 50));
  }
  const auto spread = surface_layer_spread(*avatar);
  EXPECT_NEAR(spread.item<double>(), 0.25, 1e-4);
  spread.backward();
  const auto along = (avatar->means().grad() * normals).sum(1);
  // Descent lowers the higher half and raises the lower one, along the normals only.
  EXPECT_GT(along.narrow(0, 0, 50).min().item<double>(), 0.0);
  EXPECT_LT(along.narrow(0, 50, 50).max().item<double>(), 0.0);
  const auto across = avatar->means().grad() - along.unsqueeze(1) * normals;
  EXPECT_LT(across.abs().max().item<double>(), 1e-6 * along.abs().max().item<double>() + 1e-12);
}

}  // namespace
}  // namespace fskin
