#include "fskin/losses/canonical_sparsity.h"

#include <ATen/CPUGeneratorImpl.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/models/forward_skinning_model.h"
#include "fskin/data/canonical_skeleton.h"
#include "fskin/training/occupancy_training.h"
#include "test_util.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

namespace fskin {
namespace {

using testing::SyntheticLimb;

TEST(CanonicalSparsity, IsBceTowardsOutsideAtUniformPointsOfTheBox) {
  const SyntheticLimb limb({0.0});
  torch::manual_seed(0);
  ForwardSkinningModel model(model_options(testing::tiny_config(), limb.skeleton()).forward_skinning);
  const Box box = canonical_bounds(limb.skeleton(), 0.1);
  const auto pose = torch::zeros({2, 3, 3});
  auto generator = at::make_generator<at::CPUGeneratorImpl>(7);
  const auto loss = canonical_sparsity_loss(model, box, pose, 64, generator);

  // The same points drawn again: uniform in the box, BCE against 0.
  auto again = at::make_generator<at::CPUGeneratorImpl>(7);
  const auto unit = at::rand({2, 64, 3}, again, c10::kFloat);
  const auto lo = torch::tensor({box.min[0], box.min[1], box.min[2]}, torch::kFloat32);
  const auto hi = torch::tensor({box.max[0], box.max[1], box.max[2]}, torch::kFloat32);
  const auto points = lo + unit * (hi - lo);
  EXPECT_TRUE((points >= lo).all().item<bool>() && (points <= hi).all().item<bool>());
  const auto logits = model.canonical_logits(points, pose);
  const auto expected = torch::binary_cross_entropy_with_logits(logits, torch::zeros_like(logits));
  EXPECT_NEAR(loss.item<double>(), expected.item<double>(), 1e-6);
  EXPECT_GT(loss.item<double>(), 0.1);  // the geometric init is "inside" over much of the box

  // It shapes the occupancy network only, not the skinning.
  model.zero_grad();
  loss.backward();
  double occupancy_grad = 0, skinning_grad = 0;
  for (const auto& p : model.named_parameters()) {
    if (!p.value().grad().defined()) continue;
    const double g = p.value().grad().abs().sum().item<double>();
    (p.key().rfind("skinning", 0) == 0 ? skinning_grad : occupancy_grad) += g;
  }
  EXPECT_GT(occupancy_grad, 0.0);
  EXPECT_EQ(skinning_grad, 0.0);
}

// Fraction of canonical points whose signed distance to the true limb (two
// capsules along x) is above `above` and below `below` that the trained run
// calls inside.
double inside_fraction(const std::string& run, const SyntheticLimb& limb, double above, double below) {
  auto model = load_trained_model(run, limb.skeleton());
  model->train(false);
  model->freeze_for_inference();
  torch::NoGradGuard no_grad;
  torch::manual_seed(3);
  const auto x = torch::rand({1, 20000, 3}) * torch::tensor({1.8f, 1.2f, 1.2f}) - torch::tensor({0.9f, 0.6f, 0.6f});
  const auto along = x.select(-1, 0).clamp(-0.6, 0.6);
  const auto distance = torch::sqrt((x.select(-1, 0) - along).pow(2) + x.select(-1, 1).pow(2) +
                                    x.select(-1, 2).pow(2)) - SyntheticLimb::kRadius;
  const auto region = (distance > above) & (distance < below);
  const auto inside = model->canonical_logits(x, torch::zeros({1, 3, 3})) > 0;
  return (inside & region).sum().item<double>() / region.sum().item<double>();
}

TEST(CanonicalSparsity, TrainingWithItLeavesLessInsideAwayFromTheShape) {
  const SyntheticLimb limb(testing::training_angles());
  auto config = testing::tiny_config();
  config.steps = 150;
  config.checkpoint_every = 150;
  const auto plain = testing::temp_dir("sparsity_off");
  train(config, limb, {plain.string(), false, false, nullptr});
  config.canonical_sparsity_weight = 0.3;
  const auto sparse = testing::temp_dir("sparsity_on");
  train(config, limb, {sparse.string(), false, false, nullptr});
  EXPECT_GT(testing::log_column(sparse, "sparsity").back(), 0.0);
  const double without = inside_fraction(plain.string(), limb, 0.1, 1e9);
  const double with = inside_fraction(sparse.string(), limb, 0.1, 1e9);
  const double core_without = inside_fraction(plain.string(), limb, -1e9, -0.05);
  const double core_with = inside_fraction(sparse.string(), limb, -1e9, -0.05);
  std::printf("inside, > 0.1 outside the limb: %.4f without, %.4f with the prior; "
              "> 0.05 inside the limb: %.4f without, %.4f with\n", without, with, core_without, core_with);
  EXPECT_LT(with, 0.8 * without);
  EXPECT_GT(core_with, 0.95);  // the shape itself is kept
}

}  // namespace
}  // namespace fskin
