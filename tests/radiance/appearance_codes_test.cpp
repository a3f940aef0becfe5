#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/radiance/appearance_codes.h"
#include "fskin/radiance/avatar_config.h"
#include "fskin/radiance/avatar_evaluation.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/radiance_field.h"
#include "dark_frame_dataset.h"
#include "test_util.h"
#include "tiny_image_dataset.h"

namespace fskin {
namespace {

RadianceField field_with_codes(int64_t dim) {
  RadianceFieldOptions options;
  options.appearance_dim = dim;
  return testing::small_radiance_field(options);
}

TEST(AppearanceCodes, TheHeadStartsNeutralAndNeverChangesDensity) {
  torch::manual_seed(0);
  auto field = field_with_codes(4);
  const auto x = torch::rand({64, 3}) * 1.6 - 0.8;
  const auto code = torch::randn({4});
  // An untrained head leaves the colour as it is, with any code.
  EXPECT_TRUE(torch::equal(field->forward(x).rgb, field->forward(x, {}, code).rgb));
  // A trained one changes the colour with the code, never the density.
  field->forward(x, {}, code).rgb.sum().backward();
  auto parameters = field->named_parameters();
  ASSERT_TRUE(parameters.contains("appearance_mlp.2.weight"));
  EXPECT_GT(parameters["appearance_mlp.2.weight"].grad().abs().sum().item<double>(), 0);
  {
    torch::NoGradGuard no_grad;
    parameters["appearance_mlp.2.weight"].normal_(0, 0.5);
  }
  const auto with = field->forward(x, {}, code), without = field->forward(x);
  EXPECT_FALSE(torch::allclose(with.rgb, without.rgb));
  EXPECT_TRUE(torch::equal(with.sigma, without.sigma));
  testing::expect_error([&] { field->forward(x, {}, torch::zeros({3})); }, {"appearance code"});
  EXPECT_FALSE(field_with_codes(0)->named_parameters().contains("appearance_mlp.0.weight"));
}

TEST(AppearanceCodes, CodesAreCentredPerFrameAndFoundByTheirBones) {
  torch::manual_seed(1);
  const auto bones = torch::eye(4).expand({3, 2, 4, 4}).clone();
  bones[1][0][0][3] = 0.5;
  bones[2][1][1][3] = -0.5;
  AppearanceCodes codes(bones, 5);
  EXPECT_EQ(codes->frames(), 3);
  EXPECT_LT(codes->codes().mean(0).abs().max().item<double>(), 1e-6);
  EXPECT_GT(codes->codes().abs().max().item<double>(), 0);
  {
    torch::NoGradGuard no_grad;
    codes->code(1).add_(1.0);
  }
  codes->center();
  EXPECT_LT(codes->codes().mean(0).abs().max().item<double>(), 1e-6);
  EXPECT_TRUE(torch::equal(codes->code_for(bones[2]), codes->code(2).detach()));
  EXPECT_FALSE(codes->code_for(torch::eye(4).expand({2, 4, 4}) * 2).defined());
  // Only the frames a step rendered keep gradients.
  (codes->code(0).sum() + codes->code(2).sum()).backward();
  EXPECT_TRUE(codes->code(0).grad().defined());
  codes->forget_gradients();
  EXPECT_FALSE(codes->code(0).grad().defined());
  // Saved and read back.
  torch::serialize::OutputArchive out;
  codes->save(out);
  const auto file = (testing::temp_dir("appearance_codes") / "codes.pt").string();
  out.save_to(file);
  torch::serialize::InputArchive in;
  in.load_from(file);
  const auto read = AppearanceCodesImpl::read(in);
  EXPECT_EQ(read->dim(), 5);
  EXPECT_TRUE(torch::equal(read->codes(), codes->codes()));
  testing::expect_error([&] { AppearanceCodes(bones, 0); }, {"code length must be within 1..1024"});
}

TEST(AppearanceCodes, AFrameLitDifferentlyIsLearnedByItsCode) {
  const auto data_dir = testing::dataset_with_a_dark_frame("appearance_dark_frame", 0.4);
  std::string run;
  const auto train = [&](const std::string& name, int64_t dim) {
    auto options = testing::tiny_training(name, 150, 1024);
    options.data_dir = data_dir;
    options.avatar.field.appearance_dim = dim;
    train_avatar(options);
    run = options.out_dir;
    return evaluate_avatar_run(options.out_dir, "", "train", 0, false);
  };
  const auto plain = train("appearance_off", 0);
  const auto coded = train("appearance_on", 8);
  // Without codes the field averages the dark frame and the others; with
  // them, each frame gets its own brightness.
  EXPECT_GT(coded.mean_psnr, plain.mean_psnr + 2.0) << plain.mean_psnr << " -> " << coded.mean_psnr;
  const auto trained = TrainedAvatar::load(run);
  ASSERT_TRUE(trained.appearance);
  EXPECT_EQ(trained.appearance->dim(), 8);
  EXPECT_EQ(avatar_config_document(trained.options).at("model").at("field").at("appearance").at("dim"), 8);
  const ImageDataset data(data_dir);
  const auto split = data.load_split("train");
  EXPECT_TRUE(trained.appearance_for(split.bone_transforms[0]).defined());
  const auto novel = data.load_split("novel_pose");
  EXPECT_FALSE(trained.appearance_for(novel.bone_transforms[0]).defined());
}

}  // namespace
}  // namespace fskin
