#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/radiance/avatar_config.h"
#include "fskin/radiance/avatar_evaluation.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/radiance_field.h"
#include "fskin/skeleton/rotations.h"
#include "test_util.h"
#include "tiny_image_dataset.h"

namespace fskin {
namespace {

RadianceField small_field(const std::string& shading) {
  RadianceFieldOptions options;
  options.shading = shading;
  return testing::small_radiance_field(options);
}

TEST(Shading, LambertColoursFollowTheSamplesRotation) {
  torch::manual_seed(0);
  auto field = small_field("lambert");
  const auto x = torch::rand({64, 3}) * 1.6 - 0.8;
  const auto identity = torch::eye(3).expand({64, 3, 3}).contiguous();
  const auto turned = axis_angle_to_matrix(torch::tensor({M_PI, 0.0, 0.0}, torch::kFloat32)).expand({64, 3, 3});
  const auto albedo = field->forward(x).rgb;
  const auto facing = field->forward(x, identity), away = field->forward(x, turned.contiguous());
  // The same density; the colour is the albedo times a shade that depends on R.
  EXPECT_TRUE(torch::equal(facing.sigma, away.sigma));
  EXPECT_FALSE(torch::allclose(facing.rgb, away.rgb));
  const auto shade = facing.rgb / albedo;
  EXPECT_TRUE(torch::allclose(shade.select(1, 0), shade.select(1, 1), 1e-4, 1e-5));
  EXPECT_GT(shade.min().item<double>(), 0);
  // The light and the ambient term learn.
  facing.rgb.sum().backward();
  auto parameters = field->named_parameters();
  ASSERT_TRUE(parameters.contains("light") && parameters.contains("ambient"));
  EXPECT_GT(parameters["ambient"].grad().abs().item<double>(), 0);
  EXPECT_TRUE(parameters["light"].grad().defined());
}

TEST(Shading, AnUnshadedFieldIgnoresRotationsAndHasNoLight) {
  torch::manual_seed(0);
  auto field = small_field("none");
  const auto x = torch::rand({16, 3}) - 0.5;
  const auto turned = axis_angle_to_matrix(torch::tensor({0.0, 1.0, 0.0}, torch::kFloat32)).expand({16, 3, 3});
  EXPECT_TRUE(torch::equal(field->forward(x).rgb, field->forward(x, turned.contiguous()).rgb));
  EXPECT_FALSE(field->named_parameters().contains("light"));
  testing::expect_error([] { small_field("phong"); }, {"shading must be none or lambert"});
}

TEST(Shading, ALambertAvatarTrainsSavesAndRenders) {
  auto options = testing::tiny_training("shading_lambert", 30, 256);
  options.avatar.field.shading = "lambert";
  train_avatar(options);
  auto trained = TrainedAvatar::load(options.out_dir);
  EXPECT_EQ(trained.options.avatar.field.shading, "lambert");
  EXPECT_EQ(avatar_config_document(trained.options).at("model").at("field").at("shading"), "lambert");
  const auto light = trained.avatar->field()->named_parameters()["light"];
  EXPECT_FALSE(torch::allclose(light, torch::tensor({0.0f, 0.5f, 0.5f})));  // it learned from the init
  const ImageDataset data(options.data_dir);
  const auto scores = evaluate_avatar(trained.avatar, data, "novel_pose", 1, false);
  EXPECT_GT(scores.mean_psnr, 5.0);
}

}  // namespace
}  // namespace fskin
