#include <gtest/gtest.h>
#include <torch/torch.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "fskin/radiance/avatar.h"
#include "fskin/radiance/avatar_config.h"
#include "fskin/radiance/avatar_export.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/image_rays.h"
#include "test_util.h"
#include "tiny_image_dataset.h"

namespace fskin {
namespace {

AvatarOptions learned_avatar() {
  auto options = testing::small_avatar();
  options.skinning = "learned";
  return options;
}

TEST(LearnedSkinning, StartsAtThePresetWeightsAndLearnsThroughTheRenderer) {
  torch::manual_seed(0);
  const ImageDataset data(testing::tiny_image_dataset().dir);
  Avatar preset(data.character(), testing::small_avatar());
  Avatar learned(data.character(), learned_avatar());
  EXPECT_FALSE(preset->learns_skinning());
  EXPECT_FALSE(preset->named_parameters().contains("skinning_logits"));
  ASSERT_TRUE(learned->learns_skinning());
  // The start: the preset weights, up to the 1e-3 floor per bone.
  const auto lo = learned->canonical_lower(), hi = learned->canonical_upper();
  const auto points = (torch::rand({500, 3}) * 0.8 + 0.1) *
                          torch::tensor({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}, torch::kFloat32) +
                      torch::tensor({lo[0], lo[1], lo[2]}, torch::kFloat32);
  const auto w_preset = preset->deformer().field().weights(points.unsqueeze(0));
  const auto w_learned = learned->deformer().field().weights(points.unsqueeze(0));
  const double J = static_cast<double>(data.character().num_joints());
  EXPECT_LT((w_preset - w_learned).abs().max().item<double>(), 1e-3 * J + 1e-4);
  EXPECT_LT(learned->skinning_prior().item<double>(), 1e-3);
  // A training image's rays reach the grid's logits through the deformer.
  const auto split = data.load_split("train");
  const auto background = torch::tensor({data.background()[0], data.background()[1], data.background()[2]});
  const auto rays = sample_image_rays(split, 0, mask_box(split.masks[0], 0.2), 256, 0.9, "dataset", background);
  learned->refresh_skinning();
  const auto frame = learned->pose(split.bone_transforms[0]);
  const auto rendered = learned->render_rays(frame, rays.origins, rays.directions, rays.background, true);
  (rendered.color.sum() + rendered.opacity.sum()).backward();
  const auto grad = learned->named_parameters()["skinning_logits"].grad();
  ASSERT_TRUE(grad.defined());
  EXPECT_GT(grad.abs().sum().item<double>(), 0);
  testing::expect_error(
      [&] {
        auto bad = testing::small_avatar();
        bad.skinning = "painted";
        Avatar(data.character(), bad);
      },
      {"skinning must be preset or learned"});
}

TEST(LearnedSkinning, TrainsSavesAndExportsTheLearnedWeights) {
  auto options = testing::tiny_training("learned_skinning", 150, 1024);
  options.avatar = learned_avatar();
  options.log_every = 5;
  options.decay_fraction = 0;  // a constant learning rate: the most progress in few steps
  train_avatar(options);
  auto trained = TrainedAvatar::load(options.out_dir);
  EXPECT_EQ(avatar_config_document(trained.options).at("model").at("skinning").at("type"), "learned");
  ASSERT_TRUE(trained.avatar->learns_skinning());
  // The grid moved from its start, and stayed a partition of unity.
  const ImageDataset data(options.data_dir);
  Avatar start(data.character(), learned_avatar());
  const auto logits = trained.avatar->named_parameters()["skinning_logits"];
  EXPECT_GT((logits - start->named_parameters()["skinning_logits"]).abs().max().item<double>(), 1e-3);
  const auto at_vertices = trained.avatar->deformer().field().weights(
      data.character().mesh.vertices.to(torch::kFloat32).unsqueeze(0));
  EXPECT_LT((at_vertices.sum(-1) - 1).abs().max().item<double>(), 1e-4);
  EXPECT_GE(at_vertices.min().item<double>(), 0);
  EXPECT_GT(trained.avatar->skinning_prior().item<double>(), 0);
  // The log records the prior's term.
  std::ifstream log(options.out_dir + "/log.jsonl");
  std::string line;
  std::getline(log, line);
  EXPECT_TRUE(nlohmann::json::parse(line).contains("skinning")) << line;
  // The rigged export carries the learned weights (the grid the avatar renders with).
  auto& field = trained.avatar->deformer().field();
  const auto rigged = rigged_image_avatar(trained.avatar, data.character().skeleton, 48, {}, 10);
  const auto vertices = rigged.mesh.vertices.to(torch::kFloat32).unsqueeze(0);
  EXPECT_TRUE(torch::allclose(rigged.weights, field.weights(vertices)[0], 1e-5, 1e-6));
  EXPECT_GT((rigged.weights - start->deformer().field().weights(vertices)[0]).abs().max().item<double>(), 1e-5);
}

}  // namespace
}  // namespace fskin
