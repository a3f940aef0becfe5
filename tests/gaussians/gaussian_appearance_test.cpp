// Per-frame appearance codes of Gaussian avatars (gaussian_appearance.h): the
// network starts neutral, changes the colour with the code and nothing else,
// exports fold in its code-zero colours, and a frame lit differently from the
// others is learned by its code, saved with the run and used by evaluation.
#include "fskin/gaussians/gaussian_appearance.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/gaussians/gaussian_config.h"
#include "fskin/gaussians/gaussian_evaluation.h"
#include "fskin/gaussians/gaussian_training.h"
#include "fskin/gaussians/spherical_harmonics.h"
#include "gaussians/tiny_gaussian_training.h"
#include "radiance/dark_frame_dataset.h"
#include "test_util.h"

namespace fskin {
namespace {

TEST(GaussianAppearance, StartsNeutralAndChangesTheColourWithTheCodeAlone) {
  torch::manual_seed(0);
  const ImageDataset data(testing::tiny_image_dataset().dir);
  const auto split = data.load_split("train");
  GaussianAvatarOptions options;
  options.initial_gaussians = 500;
  GaussianAvatar plain(data.character(), options, 0);
  options.appearance.dim = 4;
  GaussianAvatar coded(data.character(), options, 0);
  ASSERT_TRUE(coded->appearance());
  EXPECT_FALSE(plain->appearance());
  const auto& bones = split.bone_transforms[0];
  const auto& camera = split.cameras[0];
  const auto code = torch::randn({4});
  // The untrained network's output layer is zero: any code draws the plain avatar.
  const auto a = plain->render(bones, camera, data.background()).image;
  EXPECT_TRUE(torch::allclose(a, coded->render(bones, camera, data.background(), code).image, 0, 1e-6));
  const auto rendered = coded->render(bones, camera, data.background(), code);
  rendered.image.sum().backward();
  auto parameters = coded->named_parameters();
  ASSERT_TRUE(parameters.contains("appearance.out.weight"));
  EXPECT_GT(parameters["appearance.out.weight"].grad().abs().sum().item<double>(), 0);
  {
    torch::NoGradGuard no_grad;
    parameters["appearance.out.weight"].normal_(0, 0.5);
    parameters["appearance.code.weight"].normal_(0, 0.5);
  }
  torch::NoGradGuard no_grad;
  const auto with = coded->render(bones, camera, data.background(), code);
  const auto other = coded->render(bones, camera, data.background(), -code);
  EXPECT_GT((with.image - other.image).abs().max().item<double>(), 0.01);
  // Colour only: the picture's opacity stays the plain avatar's.
  EXPECT_TRUE(torch::allclose(with.alpha, plain->render(bones, camera, data.background()).alpha, 0, 1e-6));
  // Exports write the colours at code zero in degree 0.
  const auto folded = coded->average_appearance_sh();
  const auto expected = spherical_harmonics_dc_color(coded->sh_dc().squeeze(1)) +
                        coded->appearance()->forward(coded->means(), {});
  EXPECT_TRUE(torch::allclose(spherical_harmonics_dc_color(folded.select(1, 0)), expected, 1e-5, 1e-5));
  EXPECT_TRUE(torch::equal(folded.narrow(1, 1, folded.size(1) - 1), coded->sh_rest()));
  testing::expect_error([&] { coded->render(bones, camera, data.background(), torch::zeros({3})); },
                        {"appearance", "code"});
  testing::expect_error([&] { plain->render(bones, camera, data.background(), code); },
                        {"without appearance codes"});
  options.appearance.dim = -1;
  testing::expect_error([&] { GaussianAvatar(data.character(), options, 0); }, {"model.appearance.dim"});
}

TEST(GaussianAppearance, AFrameLitDifferentlyIsLearnedByItsCode) {
  const auto data_dir = testing::dataset_with_a_dark_frame("gaussian_appearance_dark_frame", 0.4);
  const auto train = [&](const std::string& name, int64_t dim) {
    auto options = testing::tiny_gaussian_training(name, 200);
    options.data_dir = data_dir;
    options.avatar.appearance.dim = dim;
    train_gaussian_avatar(options);
    return options.out_dir;
  };
  const auto plain_run = train("gaussian_appearance_off", 0);
  const auto coded_run = train("gaussian_appearance_on", 8);
  const auto plain = evaluate_gaussian_avatar_run(plain_run, "", "train", 0, false, {});
  const auto coded = evaluate_gaussian_avatar_run(coded_run, "", "train", 0, false, {});
  // Without codes the colours average the dark frame and the others; with
  // them, each frame gets its own brightness.
  EXPECT_GT(coded.mean_psnr, plain.mean_psnr + 3.0) << plain.mean_psnr << " -> " << coded.mean_psnr;
  const auto trained = TrainedGaussianAvatar::load(coded_run);
  ASSERT_TRUE(trained.appearance);
  EXPECT_EQ(trained.appearance->dim(), 8);
  EXPECT_EQ(gaussian_config_document(trained.options).at("model").at("appearance").at("dim"), 8);
  const ImageDataset data(data_dir);
  EXPECT_TRUE(trained.appearance_for(data.load_split("train").bone_transforms[0]).defined());
  EXPECT_FALSE(trained.appearance_for(data.load_split("novel_pose").bone_transforms[0]).defined());
  EXPECT_FALSE(TrainedGaussianAvatar::load(plain_run).appearance);
}

}  // namespace
}  // namespace fskin
