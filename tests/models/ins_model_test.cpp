// The INS model: PIN_d -> LBS search -> PIN_c (INS eq. 16) and
// re-posing by the inverse chain (eq. 19).
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <memory>
#include <stdexcept>
#include <string>

#include "fskin/models/ins_model.h"
#include "fskin/training/occupancy_training.h"
#include "test_util.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

namespace fskin {
namespace {

using testing::SyntheticLimb;

TrainConfig ins_config(const std::string& space_output = "sine") {
  auto c = testing::tiny_config();
  c.pin_space_output = space_output;
  c.method = "ins";
  c.pin_layers = 4;
  c.pin_per_bone_dim = 4;
  c.pin_pose_hidden_dim = 16;
  c.pin_space_hidden_dim = 16;
  c.pin_map_hidden_dim = 16;
  return c;
}

// The factory's model for an "ins" config, as the InsModel it must be.
std::shared_ptr<InsModel> make_ins_model(const TrainConfig& config, const CanonicalSkeleton& skeleton) {
  auto model = std::dynamic_pointer_cast<InsModel>(make_model(config, skeleton));
  if (!model) throw std::runtime_error("make_model did not build an InsModel for method " + config.method);
  return model;
}

// Every parameter of the PINs and the pose encoder moved off its init, so
// the identities below are not the trivial ones of a zero-initialised PIN.
void randomise(InsModel& model) {
  torch::NoGradGuard no_grad;
  for (auto& item : model.named_parameters()) {
    if (item.key().rfind("pin_", 0) == 0 || item.key().rfind("pose_encoder", 0) == 0) {
      item.value().add_(torch::randn_like(item.value()) * 0.3);
    }
  }
}

class InsModelBothSpaceOutputs : public ::testing::TestWithParam<std::string> {};
INSTANTIATE_TEST_SUITE_P(SpaceOutput, InsModelBothSpaceOutputs, ::testing::Values("sine", "linear"));

TEST_P(InsModelBothSpaceOutputs, ZeroRelativePoseGivesTheCanonicalShape) {
  const SyntheticLimb limb({0.0});
  torch::manual_seed(0);
  const auto model_ptr = make_ins_model(ins_config(GetParam()), limb.skeleton());
  auto& model = *model_ptr;
  randomise(model);
  model.train(false);
  model.freeze_for_inference();
  torch::NoGradGuard no_grad;
  const auto points = torch::rand({1, 200, 3}) * torch::tensor({1.2f, 0.3f, 0.3f}) - torch::tensor({0.6f, 0.15f, 0.15f});
  const auto identity = torch::eye(4).expand({1, 3, 4, 4}).contiguous();
  const auto posed = model.predict(points, identity, torch::zeros({1, 3, 3}), Aggregation::Max).logits;
  const auto canonical = model.canonical_logits(points, torch::zeros({1, 3, 3}));
  EXPECT_TRUE(torch::allclose(posed, canonical, 1e-3, 1e-3)) << (posed - canonical).abs().max().item<float>();
  EXPECT_TRUE(torch::allclose(model.repose(points, identity), points, 1e-5, 1e-5));
}

TEST_P(InsModelBothSpaceOutputs, RePosedPointsAreFoundAgainByTheSearch) {
  // Canonical points moved by the inverse chain (eq. 19) and searched for by
  // the forward chain (eq. 16) come back: the PINs are exact inverses and the
  // Broyden search inverts the LBS.
  const SyntheticLimb limb({0.0});
  torch::manual_seed(1);
  auto config = ins_config(GetParam());
  config.start_bones = "all";
  const auto model_ptr = make_ins_model(config, limb.skeleton());
  auto& model = *model_ptr;
  randomise(model);
  model.train(false);
  model.freeze_for_inference();
  torch::NoGradGuard no_grad;
  const auto x = torch::rand({1, 100, 3}) * torch::tensor({1.0f, 0.2f, 0.2f}) - torch::tensor({0.5f, 0.1f, 0.1f});
  const auto bones = SyntheticLimb::bones(0.5).unsqueeze(0);
  const auto posed = model.repose(x, bones);
  EXPECT_GT((posed - x).norm(2, -1).max().item<float>(), 0.05f);  // it really moved
  // The canonical occupancy at x is one of the candidates at x', so the hard
  // max over candidates is at least the canonical logit (minus solver error).
  const auto pose = SyntheticLimb::pose(0.5).unsqueeze(0);
  const auto found = model.predict(posed, bones, pose, Aggregation::Max).logits;
  const auto canonical = model.canonical_logits(x, pose);
  const auto recovered = (found >= canonical - 1e-2).to(torch::kFloat32).mean().item<float>();
  EXPECT_GT(recovered, 0.95f);
}

TEST(InsModel, PinsTrainAtTheirOwnLearningRate) {
  const SyntheticLimb limb({0.0});
  auto config = ins_config();
  config.pin_learning_rate_factor = 0.1;  // the paper's 1e-4 vs 1e-3
  const auto model_ptr = make_ins_model(config, limb.skeleton());
  auto& model = *model_ptr;
  const auto groups = model.parameter_groups(1e-3);
  ASSERT_EQ(groups.size(), 3u);  // occupancy, skinning, PINs + pose encoder
  EXPECT_DOUBLE_EQ(groups[0].learning_rate, 1e-3);
  EXPECT_DOUBLE_EQ(groups[1].learning_rate, 1e-3);
  EXPECT_DOUBLE_EQ(groups[2].learning_rate, 1e-4);
  EXPECT_EQ(groups[0].parameters.size() + groups[1].parameters.size() + groups[2].parameters.size(),
            model.parameters().size());
}

TEST(InsModel, LossFallsOnTheLimbWithWarmUp) {
  const SyntheticLimb limb(testing::training_angles());
  auto config = ins_config();
  config.steps = 120;
  config.checkpoint_every = 120;
  config.warmup_steps = 20;
  config.warmup_factor = 0.2;
  config.grad_clip = 4.0;
  const auto run = testing::temp_dir("ins_limb");
  train(config, limb, {run.string(), false, false, nullptr});
  const auto bce = testing::log_column(run, "bce");
  const auto lr = testing::log_column(run, "lr");
  ASSERT_EQ(bce.size(), 120u);
  EXPECT_NEAR(lr.front(), 0.2 * config.learning_rate, 1e-9);  // warm-up starts at 0.2x
  EXPECT_NEAR(lr.back(), config.learning_rate, 1e-9);
  EXPECT_LT(testing::mean(bce, 100, 120), 0.8 * testing::mean(bce, 0, 20));
  std::filesystem::remove_all(run);
}

}  // namespace
}  // namespace fskin
