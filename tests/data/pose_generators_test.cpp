#include "fskin/data/pose_generators.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/body/character.h"
#include "test_util.h"

namespace fskin {
namespace {

std::vector<std::string> generic_names(int n) {
  std::vector<std::string> names;
  for (int j = 0; j < n; ++j) names.push_back("joint_" + std::to_string(j));
  return names;
}

TEST(PoseGenerators, TrainingPosesStayInTheTrainingRanges) {
  const auto& names = smpl_joint_names();
  const auto set = make_training_poses(names, {8, 25, 3});
  ASSERT_EQ(set.poses.sizes(), (std::vector<int64_t>{200, 24, 3}));
  EXPECT_EQ(set.joint_names, names);
  for (int64_t i = 0; i < set.size(); ++i)
    EXPECT_LE(training_range_excess(names, set.poses[i]), 1e-6) << "pose " << i;
  // Natural motions move: joint angles vary within a sequence, but smoothly.
  const auto seq = set.poses.slice(0, 0, 25);
  EXPECT_GT((seq.amax(0) - seq.amin(0)).max().item<float>(), 0.3f);
  EXPECT_LT((seq.slice(0, 1) - seq.slice(0, 0, -1)).abs().max().item<float>(), 0.35f);
}

TEST(PoseGenerators, OodPosesExceedTheTrainingRanges) {
  const auto& names = smpl_joint_names();
  const auto set = make_ood_poses(names, {60, 4});
  ASSERT_EQ(set.poses.sizes(), (std::vector<int64_t>{60, 24, 3}));
  double largest = 0;
  for (int64_t i = 0; i < set.size(); ++i) {
    const double excess = training_range_excess(names, set.poses[i]);
    EXPECT_GE(excess, kOodMargin) << "pose " << i;
    largest = std::max(largest, excess);
  }
  EXPECT_GT(largest, 0.8);  // e.g. a leg raised 90 degrees where training stops at 40
  // The OOD set reaches beyond the training set's own extremes.
  const auto train = make_training_poses(names, {10, 30, 4});
  EXPECT_GT(set.poses.abs().amax({0}).max().item<float>(),
            train.poses.abs().amax({0}).max().item<float>() + 0.5f);
}

TEST(PoseGenerators, AnySkeletonWorks) {
  const auto names = generic_names(5);
  const auto train = make_training_poses(names, {2, 10, 0});
  for (int64_t i = 0; i < train.size(); ++i)
    EXPECT_LE(training_range_excess(names, train.poses[i]), 1e-6);
  EXPECT_GT(train.poses.abs().max().item<float>(), 0.05f);
  const auto ood = make_ood_poses(names, {20, 0});
  for (int64_t i = 0; i < ood.size(); ++i)
    EXPECT_GE(training_range_excess(names, ood.poses[i]), kOodMargin);
}

TEST(PoseGenerators, SeededAndDeterministic) {
  const auto& names = smpl_joint_names();
  EXPECT_TRUE(torch::equal(make_training_poses(names, {3, 5, 7}).poses,
                           make_training_poses(names, {3, 5, 7}).poses));
  EXPECT_FALSE(torch::equal(make_training_poses(names, {3, 5, 7}).poses,
                            make_training_poses(names, {3, 5, 8}).poses));
  EXPECT_TRUE(torch::equal(make_ood_poses(names, {5, 1}).poses, make_ood_poses(names, {5, 1}).poses));
  // The first sequence does not depend on how many follow.
  EXPECT_TRUE(torch::equal(make_training_poses(names, {1, 5, 7}).poses,
                           make_training_poses(names, {3, 5, 7}).poses.slice(0, 0, 5)));
}

TEST(PoseGenerators, PoseFileRoundTrip) {
  const auto dir = testing::temp_dir("pose_generators");
  const auto set = make_ood_poses(smpl_joint_names(), {4, 2});
  set.save((dir / "ood.npz").string());
  const auto loaded = PoseSet::load((dir / "ood.npz").string());
  EXPECT_TRUE(torch::equal(loaded.poses, set.poses));
  EXPECT_EQ(loaded.joint_names, set.joint_names);
  std::filesystem::remove_all(dir);
}

TEST(PoseGenerators, RejectsBadArguments) {
  testing::expect_error([] { make_training_poses({}, {}); }, {"no joints"});
  testing::expect_error([] { make_ood_poses(generic_names(2), {0, 0}); }, {"count"});
}

}  // namespace
}  // namespace fskin
