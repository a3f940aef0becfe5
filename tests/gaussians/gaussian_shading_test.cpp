// Shading of Gaussian avatars (gaussian_shading.h): the posed normal of a
// Gaussian, the irradiance's start and fit of a distant light, and an avatar
// with shading that starts as the unshaded one, learns its lighting from lit
// images and renders novel poses of them better than without.
#include "fskin/gaussians/gaussian_shading.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/gaussians/gaussian_evaluation.h"
#include "fskin/gaussians/gaussian_training.h"
#include "fskin/skeleton/rotations.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

TEST(GaussianShading, PosedNormalsAreTheLocalZAxesCarriedAsAPlanesNormal) {
  torch::manual_seed(0);
  const int64_t n = 64;
  const auto rotations = torch::randn({n, 4}, torch::kFloat64);
  // Blended transforms: rotations with shear and scale, as LBS between bones gives.
  const auto linear = torch::eye(3, torch::kFloat64) + 0.15 * torch::randn({n, 3, 3}, torch::kFloat64);
  const auto normals = posed_gaussian_normals(rotations, linear);
  const auto r = quaternion_to_matrix(rotations / rotations.norm(2, 1, true));
  for (int64_t i = 0; i < n; ++i) {
    ASSERT_GT(torch::det(linear[i]).item<double>(), 0);
    // A plane's normal maps by A^-T: it stays perpendicular to the posed disc.
    auto expected = torch::matmul(torch::inverse(linear[i]).transpose(0, 1), r[i].select(1, 2));
    expected = expected / expected.norm();
    EXPECT_TRUE(torch::allclose(normals[i], expected, 1e-9, 1e-9)) << i;
    EXPECT_LT(torch::dot(normals[i], torch::matmul(linear[i], r[i].select(1, 0))).abs().item<double>(), 1e-9);
  }
  // A rotation of the body turns them with it.
  const auto turn = quaternion_to_matrix(torch::tensor({0.8, 0.0, 0.6, 0.0}, torch::kFloat64));
  EXPECT_TRUE(torch::allclose(posed_gaussian_normals(rotations, torch::matmul(turn, linear)),
                              torch::matmul(normals, turn.transpose(0, 1)), 1e-9, 1e-9));
}

TEST(GaussianShading, StartsAtAShadeOfOneAndFitsADistantLightWithAmbient) {
  torch::manual_seed(1);
  GaussianShading shading;
  auto normals = torch::randn({2000, 3});
  normals = normals / normals.norm(2, 1, true);
  EXPECT_TRUE(torch::allclose(shading->forward(normals), torch::ones({2000, 3}), 0, 1e-6));
  // Lambert under one distant light and an ambient term, a colour each.
  const auto light = torch::tensor({0.3f, 1.0f, 0.6f}) / std::sqrt(1.45f);
  const auto target = torch::tensor({0.3f, 0.25f, 0.2f}) +
                      torch::tensor({0.7f, 0.6f, 0.5f}) * torch::relu(torch::matmul(normals, light)).unsqueeze(1);
  const double before = (shading->forward(normals) - target).pow(2).mean().sqrt().item<double>();
  torch::optim::Adam adam(shading->parameters(), torch::optim::AdamOptions(2e-2));
  for (int step = 0; step < 600; ++step) {
    adam.zero_grad();
    const auto loss = (shading->forward(normals) - target).pow(2).mean();
    loss.backward();
    adam.step();
  }
  const double after = (shading->forward(normals) - target).pow(2).mean().sqrt().item<double>();
  // Degree 2 holds a clamped cosine to a few per cent of the light.
  EXPECT_LT(after, 0.04) << "before " << before;
  EXPECT_LT(after, 0.15 * before);
}

TEST(GaussianShading, AnAvatarWithShadingStartsAsTheUnshadedOneAndItsLightingLearns) {
  const ImageDataset data(testing::tiny_image_dataset().dir);
  const auto split = data.load_split("train");
  GaussianAvatarOptions options;
  options.initial_gaussians = 500;
  options.initial_thickness = 1;  // spheres: their orientation draws nothing, shading's z axes still face outward
  GaussianAvatar plain(data.character(), options, 0);
  options.shading = "irradiance";
  GaussianAvatar shaded(data.character(), options, 0);
  ASSERT_TRUE(shaded->shading());
  EXPECT_FALSE(plain->shading());
  const auto a = plain->render(split.bone_transforms[0], split.cameras[0], data.background()).image;
  const auto b = shaded->render(split.bone_transforms[0], split.cameras[0], data.background());
  EXPECT_TRUE(torch::allclose(a, b.image, 0, 1e-6));
  // The discs' z axes are the outward normals of the faces they sit on:
  // posed by the rest pose, they point away from the body's centre on average.
  {
    torch::NoGradGuard no_grad;
    const auto identity = torch::eye(4).expand({data.character().num_joints(), 4, 4});
    const auto posed = shaded->pose(identity);
    const auto normals = posed_gaussian_normals(shaded->rotations(), posed.linear);
    const auto outward = shaded->means() - shaded->means().mean(0);
    EXPECT_GT((normals * outward).sum(1).gt(0).to(torch::kFloat64).mean().item<double>(), 0.8);
  }
  b.image.sum().backward();
  ASSERT_TRUE(shaded->shading()->lighting().grad().defined());
  EXPECT_GT(shaded->shading()->lighting().grad().abs().sum().item<double>(), 0);
  options.shading = "phong";
  testing::expect_error([&] { GaussianAvatar(data.character(), options, 0); }, {"shading", "phong"});
}

}  // namespace
}  // namespace fskin
