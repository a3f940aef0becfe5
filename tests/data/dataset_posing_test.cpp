#include "fskin/data/dataset_posing.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>

#include "fskin/body/character.h"
#include "fskin/data/dataset.h"
#include "fskin/data/dataset_builder.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/pose_generators.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

CharacterOptions small_character(uint64_t seed) {
  CharacterOptions options;
  options.seed = seed;
  options.resolution = 56;
  return options;
}

TEST(DatasetPosing, ReproducesTheBoneTransformsOfTheDatasetFrames) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  const auto dir = testing::temp_dir("dataset_posing");
  const auto model = make_character_model(small_character(0));
  const auto model_path = (dir / "model.npz").string();
  model.save(model_path);
  auto poses = make_training_poses(model.data().joint_names, {1, 4, 3});
  poses.trans = torch::randn({4, 3}) * 0.1;  // the root translation must come through too
  DatasetBuildOptions options;
  options.out_dir = (dir / "set").string();
  options.model_source = model_path;
  options.sampling.uniform_points = 100;
  options.sampling.surface_points = 100;
  options.val_fraction = 0.25;
  options.test_fraction = 0.25;
  options.progress = false;
  build_dataset(model, poses, PoseSet{}, options);

  const auto posing = DatasetPosing::load(options.out_dir);
  EXPECT_TRUE(torch::equal(posing.canonical_pose(), da_pose(model.skeleton())));
  const auto bones = posing.bone_transforms(poses, "poses");
  ASSERT_EQ(bones.sizes(), (std::vector<int64_t>{4, 24, 4, 4}));
  // Splits are contiguous blocks of the pose file: train, val, test_within.
  int64_t pose = 0;
  for (const std::string split : {"train", "val", "test_within"}) {
    const auto set = Dataset::load(options.out_dir, split);
    for (int64_t f = 0; f < set.size(); ++f, ++pose)
      EXPECT_TRUE(torch::allclose(bones[pose], set.frame(f).bone_transforms, 1e-5, 1e-5))
          << split << " frame " << f << ": max difference "
          << (bones[pose] - set.frame(f).bone_transforms).abs().max().item<float>();
  }
  EXPECT_EQ(pose, 4);

  PoseSet three_joints{torch::zeros({1, 3, 3}), torch::zeros({1, 3}), {}};
  testing::expect_error([&] { posing.bone_transforms(three_joints, "three.npz"); }, {"three.npz", "[*, 24, 3]"});
  // Another body (other proportions) is refused rather than silently used.
  const auto other_path = (dir / "other.npz").string();
  make_character_model(small_character(7)).save(other_path);
  testing::expect_error([&] { DatasetPosing::load(options.out_dir, other_path); },
                        {"other.npz", "not the one the dataset was built from"});
  // The manifest's model moved away: the error says how to go on.
  fs::rename(model_path, dir / "moved.npz");
  testing::expect_error([&] { DatasetPosing::load(options.out_dir); }, {"manifest.json", "model.npz", "--model"});
  EXPECT_NO_THROW(DatasetPosing::load(options.out_dir, (dir / "moved.npz").string()));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fskin
