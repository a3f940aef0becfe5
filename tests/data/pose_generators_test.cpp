#include "fskin/data/pose_generators.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/body/character.h"
#include "fskin/body/quadruped.h"
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

TEST(PoseGenerators, AnySkeletonTakesItsRangesFromData) {
  const auto names = generic_names(5);
  // fskin has no motions for these names: it says so, and what to pass instead.
  testing::expect_error([&] { make_training_poses(names, {2, 10, 0}); }, {"no built-in motions", "--ranges-from"});
  testing::expect_error([&] { training_ranges(names); }, {"joint_0"});
  // Ranges from a "clip": joint 2 never moves, joint 4 only about y.
  PoseSet clip;
  clip.poses = torch::zeros({3, 5, 3});
  clip.poses[0][0] = torch::tensor({-0.2, 0.1, 0.0});
  clip.poses[1][0] = torch::tensor({0.4, -0.1, 0.3});
  clip.poses[2][1] = torch::tensor({0.5, 0.5, 0.5});
  clip.poses[1][3] = torch::tensor({-0.3, 0.0, 0.2});
  clip.poses[2][4] = torch::tensor({0.0, 0.6, 0.0});
  clip.trans = torch::zeros({3, 3});
  const auto ranges = ranges_of_poses(clip, "clip");
  ASSERT_EQ(ranges.size(), 5u);
  EXPECT_NEAR(ranges[0].low[0], -0.2, 1e-7);
  EXPECT_NEAR(ranges[0].high[2], 0.3, 1e-7);
  EXPECT_EQ(ranges[2].high, (std::array<double, 3>{0, 0, 0}));
  const auto train = make_training_poses(names, ranges, {4, 10, 0});
  for (int64_t i = 0; i < train.size(); ++i) EXPECT_LE(range_excess(ranges, train.poses[i]), 1e-6);
  EXPECT_EQ(train.poses.select(1, 2).abs().max().item<float>(), 0.0f);  // still
  EXPECT_GT((train.poses.select(1, 4).select(1, 1).amax() - train.poses.select(1, 4).select(1, 1).amin()).item<float>(),
            0.2f);
  const auto ood = make_ood_poses(names, ranges, {20, 0});
  for (int64_t i = 0; i < ood.size(); ++i) {
    EXPECT_GE(range_excess(ranges, ood.poses[i]), kOodMargin);
    EXPECT_EQ(ood.poses[i][2].abs().max().item<float>(), 0.0f) << "a joint that never moves is not pushed";
  }
}

TEST(PoseGenerators, QuadrupedMotionsStayInRangeAndOodGoesBeyond) {
  const auto& names = quadruped_joint_names();
  EXPECT_EQ(builtin_motions(names), "quadruped");
  EXPECT_EQ(builtin_motions(smpl_joint_names()), "smpl");
  const auto train = make_training_poses(names, {8, 20, 1});
  for (int64_t i = 0; i < train.size(); ++i) ASSERT_LE(training_range_excess(names, train.poses[i]), 1e-6);
  // Legs, neck and tail all move.
  const auto spread = train.poses.amax(0) - train.poses.amin(0);  // [J, 3]
  for (const char* joint : {"upper_arm_l", "thigh_r", "neck_base", "tail_3", "ear_l_base"}) {
    const auto j = std::find(names.begin(), names.end(), joint) - names.begin();
    EXPECT_GT(spread[j].max().item<float>(), 0.15f) << joint;
  }
  const auto ood = make_ood_poses(names, {40, 2});
  for (int64_t i = 0; i < ood.size(); ++i) EXPECT_GE(training_range_excess(names, ood.poses[i]), kOodMargin) << i;
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
  EXPECT_FALSE(loaded.joint_translations.defined());
  // Joint translations travel with the poses and are checked like them.
  auto moved = set;
  moved.joint_translations = torch::randn({4, static_cast<int64_t>(smpl_joint_names().size()), 3}) * 0.01;
  moved.save((dir / "moved.npz").string());
  EXPECT_TRUE(torch::equal(PoseSet::load((dir / "moved.npz").string()).joint_translations, moved.joint_translations));
  EXPECT_TRUE(torch::equal(moved.slice(1, 3).joint_translations, moved.joint_translations.slice(0, 1, 3)));
  moved.joint_translations = torch::zeros({4, 2, 3});
  testing::expect_error([&] { moved.save((dir / "bad.npz").string()); }, {"bad.npz", "joint_translations"});
  std::filesystem::remove_all(dir);
}

TEST(PoseGenerators, RejectsBadArguments) {
  testing::expect_error([] { make_training_poses({}, {}); }, {"no joints"});
  testing::expect_error([] { make_ood_poses(smpl_joint_names(), {0, 0}); }, {"count"});
  testing::expect_error([] { make_training_poses(generic_names(2), JointRanges(1), {1, 1, 0}); },
                        {"1 joint ranges", "2 joints"});
}

}  // namespace
}  // namespace fskin
