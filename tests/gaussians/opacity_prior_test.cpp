// The opacity prior: ln 2 for Gaussians half opaque, nearly zero for opaque
// or vanished ones, and a gradient that pushes each opacity away from one half.
#include "fskin/gaussians/opacity_prior.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

GaussianAvatar avatar_with_opacities(const torch::Tensor& opacities) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  GaussianAvatarOptions options;
  options.initial_gaussians = opacities.size(0);
  options.skinning_grid_resolution = 16;
  GaussianAvatar avatar(dataset.character(), options, 0);
  torch::NoGradGuard no_grad;
  avatar->opacity_logits().copy_(torch::log(opacities / (1 - opacities)));
  return avatar;
}

TEST(OpacityPrior, IsLn2AtOneHalfAndNearlyZeroForOpaqueOrVanishedGaussians) {
  EXPECT_NEAR(opacity_entropy(*avatar_with_opacities(torch::full({8}, 0.5f))).item<double>(), std::log(2.0), 1e-6);
  const auto binary = torch::tensor({1e-5f, 1 - 1e-5f, 1e-5f, 1 - 1e-5f});
  EXPECT_LT(opacity_entropy(*avatar_with_opacities(binary)).item<double>(), 2e-4);
}

TEST(OpacityPrior, GradientPushesOpacitiesAwayFromOneHalf) {
  auto avatar = avatar_with_opacities(torch::tensor({0.3f, 0.5f, 0.7f}));
  opacity_entropy(*avatar).backward();
  const auto grad = avatar->opacity_logits().grad();
  // Descent moves each logit against its gradient: down below one half, up above, not at all at it.
  EXPECT_GT(grad[0].item<double>(), 1e-3);
  EXPECT_NEAR(grad[1].item<double>(), 0.0, 1e-6);
  EXPECT_LT(grad[2].item<double>(), -1e-3);
}

}  // namespace
}  // namespace fskin
