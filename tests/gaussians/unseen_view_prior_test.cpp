// The unseen-view prior: the unseen view's camera keeps the pivot in place and
// turns about the picture's vertical; the opacity's entropy is ln 2 per
// half-covered pixel and pushes opacities away from one half; and a short
// training with the prior draws the held-out views more nearly opaque or empty.
#include "fskin/gaussians/unseen_view_prior.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "gaussians/tiny_gaussian_training.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

TEST(UnseenViewPrior, TheViewTurnsAboutThePicturesVerticalThroughThePivot) {
  const ImageDataset data(testing::tiny_image_dataset().dir);
  const auto split = data.load_split("train");
  const PinholeCamera& camera = split.cameras[0];
  const Eigen::Vector3d pivot = camera.centre() + 3.0 * camera.forward() + 0.2 * camera.right();
  const double radians = 0.6;
  const auto view = unseen_view(camera, radians, pivot);
  view.validate("test");
  // The pivot keeps its pixel and its distance from the eye.
  EXPECT_TRUE(view.project(pivot).isApprox(camera.project(pivot), 1e-9));
  EXPECT_NEAR((view.centre() - pivot).norm(), (camera.centre() - pivot).norm(), 1e-6);
  // The eye moves by the angle about the picture's vertical: its height along down() stays.
  const Eigen::Vector3d before = camera.centre() - pivot, after = view.centre() - pivot;
  EXPECT_NEAR(before.dot(camera.down()), after.dot(camera.down()), 1e-9);
  const auto flat = [&](const Eigen::Vector3d& v) { return Eigen::Vector3d(v - v.dot(camera.down()) * camera.down()); };
  EXPECT_NEAR(std::acos(flat(before).normalized().dot(flat(after).normalized())), radians, 1e-9);
  EXPECT_TRUE(unseen_view(camera, 0, pivot).extrinsic.isApprox(camera.extrinsic, 1e-12));
}

TEST(UnseenViewPrior, TheEntropyIsLn2PerHalfCoveredPixelAndPushesAwayFromOneHalf) {
  EXPECT_NEAR(alpha_entropy_sum(torch::full({4, 5}, 0.5)).item<double>(), 20 * std::log(2.0), 1e-5);
  EXPECT_LT(alpha_entropy_sum(torch::tensor({{0.0, 1.0}, {1.0, 0.0}})).item<double>(), 4 * 1.1e-3);
  const auto alpha = torch::tensor({0.3, 0.5, 0.7}, torch::kFloat64).requires_grad_();
  alpha_entropy_sum(alpha).backward();
  // Gradient descent lowers 0.3, raises 0.7 and leaves 0.5 be.
  EXPECT_GT(alpha.grad()[0].item<double>(), 0.5);
  EXPECT_NEAR(alpha.grad()[1].item<double>(), 0.0, 1e-12);
  EXPECT_LT(alpha.grad()[2].item<double>(), -0.5);
}

// The mean entropy of the trained avatar's opacity over the held-out views' pictures.
double held_out_entropy(const std::string& run) {
  return testing::mean_over_held_out_views(run, [](const torch::Tensor& alpha, const torch::Tensor&) {
    return alpha_entropy_sum(alpha).item<double>() / static_cast<double>(alpha.numel());
  });
}

TEST(UnseenViewPrior, TrainingWithItDrawsTheHeldOutViewsMoreNearlyOpaqueOrEmpty) {
  auto without = testing::tiny_gaussian_training("unseen_view_prior_without", 150);
  auto with = testing::tiny_gaussian_training("unseen_view_prior_with", 150);
  with.alpha_entropy_weight = 1.0;
  without.rig_silhouette_weight = with.rig_silhouette_weight = 0;  // the entropy alone
  train_gaussian_avatar(without);
  train_gaussian_avatar(with);
  const double plain = held_out_entropy(without.out_dir), prior = held_out_entropy(with.out_dir);
  EXPECT_LT(prior, 0.8 * plain) << "without " << plain << ", with " << prior;
}

}  // namespace
}  // namespace fskin
