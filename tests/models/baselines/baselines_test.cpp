// The baselines of SNARF sec. 4.2 share the trainer with SNARF; these tests
// check what each one's construction promises and that each one learns.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/models/baselines/piecewise_rigid.h"
#include "fskin/models/baselines/pose_onet.h"
#include "fskin/core/error.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/models/model_registry.h"
#include "fskin/training/occupancy_training.h"
#include "test_util.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

namespace fskin {
namespace {

using testing::SyntheticLimb;

TrainConfig baseline_config(const std::string& method) {
  auto c = testing::tiny_config();
  c.method = method;
  return c;
}

// Random posed points and the limb's bones at a few angles.
struct Probe {
  torch::Tensor points, bones, pose;
};
Probe probe(const std::vector<double>& angles) {
  torch::manual_seed(3);
  std::vector<torch::Tensor> bones, poses;
  for (double a : angles) {
    bones.push_back(SyntheticLimb::bones(a));
    poses.push_back(SyntheticLimb::pose(a));
  }
  const auto n = static_cast<int64_t>(angles.size());
  return {torch::rand({n, 50, 3}) * 1.6 - 0.8, torch::stack(bones), torch::stack(poses)};
}

TEST(Baselines, BackDStartsAsTheRigidRootTransform) {
  const SyntheticLimb limb({0.0});
  auto model = make_model(baseline_config("back-d"), limb.skeleton());
  const auto p = probe({0.4, -0.9});
  // The root bone is the identity in the limb, so canonical = posed points.
  const auto predicted = model->predict(p.points, p.bones, p.pose, Aggregation::Max).logits;
  EXPECT_TRUE(torch::allclose(predicted, model->canonical_logits(p.points, p.pose), 1e-5, 1e-5));
}

TEST(Baselines, BackLbsIsTheIdentityWhenEveryBoneIs) {
  const SyntheticLimb limb({0.0});
  auto model = make_model(baseline_config("back-lbs"), limb.skeleton());
  auto p = probe({0.4, -0.9});
  p.bones = torch::eye(4).expand({2, 3, 4, 4}).contiguous();  // whatever the weights, the blend is I
  const auto predicted = model->predict(p.points, p.bones, p.pose, Aggregation::Max).logits;
  EXPECT_TRUE(torch::allclose(predicted, model->canonical_logits(p.points, p.pose), 1e-4, 1e-4));
}

TEST(Baselines, PiecewiseIsTheMaxOverRigidlyCarriedParts) {
  PiecewiseRigidOptions options;
  options.num_bones = 3;
  options.hidden_dim = 8;
  PiecewiseRigidModel model(options);
  const auto p = probe({0.7});
  const auto logits = model.predict(p.points, p.bones, p.pose, Aggregation::Max).logits;  // [1, 50]
  // Each part sees the point carried back by its own bone alone.
  std::vector<torch::Tensor> carried;
  for (int64_t j = 0; j < 3; ++j) carried.push_back(transform_points(torch::inverse(p.bones[0][j]), p.points[0]));
  const auto parts = model.part_logits(torch::stack(carried, 1).unsqueeze(0));  // [1, 50, 3]
  EXPECT_TRUE(torch::allclose(std::get<0>(parts.max(-1)), logits, 1e-5, 1e-5));
  // The soft max lies between the mean and the max of the parts' probabilities.
  const auto soft = torch::sigmoid(model.predict(p.points, p.bones, p.pose, Aggregation::Soft).logits);
  EXPECT_TRUE(torch::all(soft <= torch::sigmoid(logits) + 1e-5).item<bool>());
  EXPECT_TRUE(torch::all(soft >= torch::sigmoid(parts).mean(-1) - 1e-5).item<bool>());
}

TEST(Baselines, PoseOnetNeedsThePose) {
  OccupancyNetworkOptions occupancy;
  occupancy.pose_dim = 0;
  testing::expect_error([&] { PoseOnetModel model(occupancy); }, {"pose-onet", "pose"});
}

class BaselineTraining : public ::testing::TestWithParam<std::string> {};

TEST_P(BaselineTraining, LossFallsOnTheLimb) {
  const SyntheticLimb limb(testing::training_angles());
  auto config = baseline_config(GetParam());
  config.steps = 150;
  config.checkpoint_every = 150;
  const auto run = testing::temp_dir("baseline_" + GetParam());
  train(config, limb, {run.string(), false, false, nullptr});
  const auto bce = testing::log_column(run, "bce");
  ASSERT_EQ(bce.size(), 150u);
  EXPECT_LT(testing::mean(bce, 120, 150), 0.8 * testing::mean(bce, 0, 30)) << GetParam();
  // A trained run reloads as the same method and predicts finite logits.
  auto model = load_trained_model(run.string(), limb.skeleton());
  const auto p = probe({0.2});
  EXPECT_TRUE(torch::isfinite(model->predict(p.points, p.bones, p.pose, Aggregation::Max).logits).all().item<bool>());
  std::filesystem::remove_all(run);
}

INSTANTIATE_TEST_SUITE_P(Methods, BaselineTraining,
                         ::testing::Values("pose-onet", "back-lbs", "back-d", "piecewise"),
                         [](const auto& info) {
                           std::string name = info.param;
                           name.erase(std::remove(name.begin(), name.end(), '-'), name.end());
                           return name;
                         });

}  // namespace
}  // namespace fskin
