#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/geometry/character_size.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/avatar_evaluation.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/image_metrics.h"
#include "fskin/radiance/pose_correction.h"
#include "fskin/radiance/pose_fitting.h"
#include "fskin/radiance/pose_perturbation.h"
#include "fskin/radiance/refined_poses.h"
#include "fskin/skeleton/rotations.h"
#include "test_util.h"
#include "tiny_image_dataset.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// A chain root -> a -> b along +x, one unit apart.
Skeleton chain() {
  Skeleton s;
  s.joint_names = {"root", "a", "b"};
  s.parents = {-1, 0, 1};
  s.rest_joints = torch::tensor({{0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {2.0f, 0.0f, 0.0f}});
  return s;
}

// Posed joint positions B_j c_j [..., J, 3].
torch::Tensor posed_joints(const torch::Tensor& bones, const Skeleton& s) {
  const auto c = torch::cat({s.rest_joints, torch::ones({s.num_joints(), 1})}, 1);
  return torch::matmul(bones, c.unsqueeze(-1)).squeeze(-1).narrow(-1, 0, 3);
}

// Bones of the chain with each joint turned by a local rotation (plain FK).
torch::Tensor chain_bones(const torch::Tensor& local_axis_angle, const Skeleton& s) {
  const auto R = axis_angle_to_matrix(local_axis_angle);
  std::vector<torch::Tensor> world;
  for (int64_t j = 0; j < 3; ++j) {
    auto local = torch::eye(4);
    local.narrow(0, 0, 3).narrow(1, 0, 3).copy_(R[j]);
    const int64_t p = s.parents[j];
    const auto offset = p < 0 ? s.rest_joints[j] : s.rest_joints[j] - s.rest_joints[p];
    local.narrow(0, 0, 3).select(1, 3).copy_(offset);
    world.push_back(p < 0 ? local : torch::matmul(world[p], local));
  }
  std::vector<torch::Tensor> bones;
  for (int64_t j = 0; j < 3; ++j) {
    auto unbind = torch::eye(4);
    unbind.narrow(0, 0, 3).select(1, 3).copy_(-s.rest_joints[j]);
    bones.push_back(torch::matmul(world[j], unbind));
  }
  return torch::stack(bones);
}

TEST(PoseCorrection, ZeroCorrectionsKeepTheBones) {
  const auto s = chain();
  const auto bones = chain_bones(0.4 * torch::randn({3, 3}), s);
  const auto out = corrected_bone_transforms(bones, torch::zeros({3, 3}), torch::zeros({3}), s, 2.0);
  EXPECT_TRUE(torch::allclose(out, bones, 1e-5, 1e-6));
}

TEST(PoseCorrection, IsForwardKinematicsWithTheLocalRotationsComposed) {
  // Correcting joint a of a posed chain by r equals posing the chain with a's
  // local rotation followed by r: the correction lives in the joint's frame
  // and carries b along.
  const auto s = chain();
  const auto local = 0.5 * torch::randn({3, 3});
  const auto bones = chain_bones(local, s);
  auto correction = torch::zeros({3, 3});
  correction[1] = torch::tensor({0.0f, 0.0f, 0.3f});
  const auto out = corrected_bone_transforms(bones, correction, torch::zeros({3}), s, 1.0);
  auto composed = local.clone();
  composed[1] = matrix_to_axis_angle(torch::matmul(axis_angle_to_matrix(local[1]), axis_angle_to_matrix(correction[1])));
  EXPECT_TRUE(torch::allclose(out, chain_bones(composed, s), 1e-4, 1e-5));
  // The joint itself stays; its child moves.
  const auto before = posed_joints(bones, s), after = posed_joints(out, s);
  EXPECT_TRUE(torch::allclose(after[0], before[0], 1e-5, 1e-5));
  EXPECT_TRUE(torch::allclose(after[1], before[1], 1e-5, 1e-5));
  EXPECT_GT((after[2] - before[2]).norm().item<double>(), 0.1);
}

TEST(PoseCorrection, RootTranslationIsInUnitsOfTheSize) {
  const auto s = chain();
  const auto bones = chain_bones(torch::zeros({3, 3}), s);
  const auto out = corrected_bone_transforms(bones, torch::zeros({3, 3}), torch::tensor({0.0f, 0.1f, 0.0f}), s, 2.0);
  const auto shift = posed_joints(out, s) - posed_joints(bones, s);
  EXPECT_TRUE(torch::allclose(shift, torch::tensor({0.0f, 0.2f, 0.0f}).expand({3, 3}), 1e-5, 1e-6));
}

TEST(PoseCorrection, GradientsAreFiniteAtZero) {
  const auto s = chain();
  const auto bones = chain_bones(0.3 * torch::randn({3, 3}), s);
  auto rotations = torch::zeros({3, 3}, torch::requires_grad());
  auto translation = torch::zeros({3}, torch::requires_grad());
  const auto target = torch::randn({3, 3});
  (posed_joints(corrected_bone_transforms(bones, rotations, translation, s, 1.0), s) * target).sum().backward();
  EXPECT_TRUE(torch::isfinite(rotations.grad()).all().item<bool>());
  EXPECT_GT(rotations.grad().abs().sum().item<double>(), 0);
  EXPECT_TRUE(torch::allclose(translation.grad(), target.sum(0), 1e-5, 1e-5));
}

TEST(PoseCorrection, ErrorsNameTheShapes) {
  const auto s = chain();
  EXPECT_THROW(corrected_bone_transforms(torch::zeros({2, 4, 4}), torch::zeros({3, 3}), torch::zeros({3}), s, 1.0),
               Error);
  EXPECT_THROW(corrected_bone_transforms(torch::eye(4).expand({3, 4, 4}), torch::zeros({3, 4}), torch::zeros({3}), s,
                                         1.0),
               Error);
  EXPECT_THROW(corrected_bone_transforms(torch::eye(4).expand({3, 4, 4}), torch::zeros({3, 3}), torch::zeros({3}), s,
                                         0.0),
               Error);
}

TEST(PoseCorrection, FramesOfImagesShareEqualPoses) {
  const auto a = torch::eye(4).expand({2, 4, 4}), b = 2 * a;
  const auto bones = torch::stack({a, b, a, b, b});
  const auto frames = frames_of_images(bones);
  EXPECT_EQ(frames, (std::vector<int64_t>{0, 1, 0, 1, 1}));
  EXPECT_TRUE(torch::equal(frame_bone_transforms(bones, frames), torch::stack({a, b})));
}

TEST(PoseCorrection, PoseErrorMeasuresAngleAndJointDistance) {
  const auto s = chain();
  const auto bones = chain_bones(torch::zeros({3, 3}), s).unsqueeze(0);
  auto turned = torch::zeros({3, 3});
  turned[0] = torch::tensor({0.0f, 0.0f, static_cast<float>(M_PI / 18)});  // 10 degrees at the root
  const auto moved = corrected_bone_transforms(bones[0], turned, torch::zeros({3}), s, 1.0).unsqueeze(0);
  const auto error = pose_error(moved, bones, s, 2.0);
  EXPECT_NEAR(error.rotation_degrees, 10.0 / 3, 0.02);  // the root turned, its children not relative to it
  // Joints 1 and 2 move on circles of radius 1 and 2: chords 2 r sin(5 deg), mean over 3 joints, over size 2.
  EXPECT_NEAR(error.joint_distance, (2 * std::sin(M_PI / 36) * 3) / 3 / 2, 1e-4);
}

TEST(PoseCorrection, AStepMovesOnlyTheFramesItRenders) {
  const auto s = chain();
  PoseCorrections corrections(torch::stack({chain_bones(torch::zeros({3, 3}), s), chain_bones(torch::ones({3, 3}), s)}));
  torch::optim::Adam adam(corrections->parameters(), torch::optim::AdamOptions(0.1));
  const auto step = [&](int64_t frame) {
    corrections->forget_gradients();
    adam.zero_grad();
    posed_joints(corrections->apply(frame, s, 1.0), s).sum().backward();
    adam.step();
  };
  step(1);
  const auto after_one = corrections->rotations()[1].clone();
  EXPECT_GT(after_one.abs().sum().item<double>(), 0);
  step(0);
  step(0);
  // Frame 1's moments do not carry it on while only frame 0 is rendered.
  EXPECT_TRUE(torch::equal(corrections->rotations()[1], after_one));
  EXPECT_GT(corrections->rotations()[0].abs().sum().item<double>(), 0);
}

TEST(PoseCorrection, CenteringRemovesTheCorrectionAllFramesShare) {
  const auto s = chain();
  const auto bones = chain_bones(torch::zeros({3, 3}), s);
  PoseCorrections corrections(torch::stack({bones, bones, bones}));
  {
    torch::NoGradGuard no_grad;
    auto parameters = corrections->parameters();
    for (auto& p : parameters) p.copy_(torch::randn(p.sizes()) + 1);  // a shared offset of 1 plus noise
  }
  const auto before = corrections->rotations();
  corrections->center();
  EXPECT_LT(corrections->rotations().mean(0).abs().max().item<double>(), 1e-6);
  EXPECT_LT(corrections->translations().mean(0).abs().max().item<double>(), 1e-6);
  // The frames' differences stay.
  EXPECT_TRUE(torch::allclose(corrections->rotations()[0] - corrections->rotations()[1], before[0] - before[1], 1e-5,
                              1e-6));
}

TEST(PosePerturbation, PerturbsTrainingPosesOnceAndKeepsTheExactOnes) {
  const ImageDataset exact(testing::tiny_image_dataset().dir), noisy(testing::perturbed_tiny_dataset());
  const auto& s = exact.character().skeleton;
  const double size = character_size(exact.character().mesh.vertices);
  for (const char* split : {"train", "novel_view"}) {
    const auto path = (fs::path(noisy.dir()) / split / "poses.npz").string();
    const auto given = noisy.load_split(split).bone_transforms;
    const auto truth = exact.load_split(split).bone_transforms;
    EXPECT_TRUE(torch::equal(io::NpzReader(path).tensor("bone_transforms_exact"), truth)) << split;
    const auto error = pose_error(given, truth, s, size);
    // 5 degrees per joint before the mean over the 3 poses is removed.
    EXPECT_GT(error.rotation_degrees, 2.0) << split;
    EXPECT_LT(error.rotation_degrees, 5.5) << split;
    EXPECT_GT(error.joint_distance, 0.003) << split;
  }
  // One noise per pose: the novel views of a training pose carry the same bones.
  const auto train = noisy.load_split("train"), novel_view = noisy.load_split("novel_view");
  for (int64_t i = 0; i < novel_view.size(); ++i) {
    bool found = false;
    for (int64_t k = 0; k < train.size(); ++k) found = found || torch::equal(novel_view.bone_transforms[i], train.bone_transforms[k]);
    EXPECT_TRUE(found) << "novel_view image " << i;
  }
  EXPECT_TRUE(torch::equal(noisy.load_split("novel_pose").bone_transforms,
                           exact.load_split("novel_pose").bone_transforms));
  // A second perturbation into the same place, or of a perturbed copy, is refused.
  PosePerturbationOptions again;
  again.data_dir = testing::tiny_image_dataset().dir;
  again.out_dir = testing::perturbed_tiny_dataset();
  EXPECT_THROW(perturb_image_dataset_poses(again), Error);
  again.data_dir = testing::perturbed_tiny_dataset();
  again.out_dir = (testing::temp_dir("perturbed_twice") / "data").string();
  EXPECT_THROW(perturb_image_dataset_poses(again), Error);
}

TEST(PoseRefinement, RenderedRaysCarryGradientsToTheBones) {
  const ImageDataset data(testing::tiny_image_dataset().dir);
  torch::manual_seed(0);
  Avatar avatar(data.character(), testing::small_avatar());
  const auto split = data.load_split("train");
  const auto frame = avatar->pose(split.bone_transforms[0]);
  auto refined = frame;
  const auto bones = split.bone_transforms[0].clone().requires_grad_(true);
  refined.bones = bones;
  const auto pixels = torch::stack({torch::arange(10, 30).to(torch::kFloat32), torch::full({20}, 20.0f)}, 1);
  const auto [origins, directions] = camera_rays(split.cameras[0], pixels);
  const auto rendered =
      avatar->render_rays(refined, origins, directions, torch::ones({20, 3}), /*jitter=*/false);
  ASSERT_GT(rendered.samples, 0);
  rendered.color.sum().backward();
  ASSERT_TRUE(bones.grad().defined());
  EXPECT_TRUE(torch::isfinite(bones.grad()).all().item<bool>());
  EXPECT_GT(bones.grad().abs().sum().item<double>(), 0);
  // Without gradients on the bones, the same rays render the same colours.
  const auto plain = avatar->render_rays(frame, origins, directions, torch::ones({20, 3}), false);
  EXPECT_TRUE(torch::allclose(plain.color, rendered.color.detach(), 1e-5, 1e-6));
}

TEST(PoseRefinement, TrainsSavesResumesAndReportsTheRefinedPoses) {
  auto options = testing::tiny_training("pose_refinement", 20, 256);
  options.data_dir = testing::perturbed_tiny_dataset();
  options.refine_poses = true;
  options.pose_learning_rate = 1e-2;
  options.checkpoint_every = 10;
  train_avatar(options);
  const auto first = refined_poses(options.out_dir);
  ASSERT_EQ(first.given.size(0), 3);  // 3 training poses, 2 views each
  EXPECT_GT(first.mean_rotation_degrees, 0);
  ASSERT_TRUE(first.exact.defined());
  EXPECT_GT(first.given_error.rotation_degrees, 2.0);
  EXPECT_GT(first.refined_error.rotation_degrees, 0);
  // The log carries the regulariser; resuming continues the corrections.
  auto more = options;
  more.steps = 30;
  more.resume = true;
  const auto summary = train_avatar(more);
  EXPECT_EQ(summary.first_step, 20);
  const auto second = refined_poses(options.out_dir);
  EXPECT_FALSE(torch::equal(second.refined, first.refined));
  const auto saved = (fs::path(options.out_dir) / "refined.npz").string();
  second.save(saved);
  const io::NpzReader file(saved);
  EXPECT_TRUE(torch::equal(file.tensor("bone_transforms"), second.refined));
  EXPECT_TRUE(file.contains("given_bone_transforms") && file.contains("bone_transforms_exact"));
  // Evaluation renders the novel views of training poses with the refined bones.
  const auto trained = TrainedAvatar::load(options.out_dir);
  ASSERT_TRUE(trained.corrections);
  const auto novel_view = ImageDataset(options.data_dir).load_split("novel_view");
  EXPECT_TRUE(torch::allclose(trained.bones_for(novel_view.bone_transforms[0]),
                              second.refined[trained.corrections->find(novel_view.bone_transforms[0])]));
  const auto novel_pose = ImageDataset(options.data_dir).load_split("novel_pose");
  EXPECT_TRUE(torch::equal(trained.bones_for(novel_pose.bone_transforms[0]), novel_pose.bone_transforms[0]));
  EXPECT_EQ(evaluate_avatar_run(options.out_dir, "", "novel_view", 0, false).frames.size(), 2u);
}

TEST(PoseFitting, SettlesOnTheOptimumOfANonSmoothLoss) {
  // L1 on the posed joints, as an image loss is: Adam at a constant rate
  // keeps stepping about its optimum; decayed, it settles (5e-5 here).
  const auto s = chain();
  const auto exact = chain_bones(torch::tensor({{0.1f, 0.0f, 0.05f}, {0.0f, 0.2f, 0.0f}, {0.0f, 0.0f, -0.1f}}), s);
  auto target = exact.clone();
  target.select(1, 0).select(1, 3) += 0.02f;  // and the whole chain shifted
  const auto start = chain_bones(torch::zeros({3, 3}), s);
  PoseFittingOptions fitting;
  fitting.steps = 200;
  fitting.regularizer = 0;
  const auto loss = [&](const torch::Tensor& bones, int64_t) {
    return (posed_joints(bones, s) - posed_joints(target, s)).abs().sum();
  };
  const auto fitted = fit_pose(start, s, 1.0, fitting, {}, loss);
  const double error = (posed_joints(fitted, s) - posed_joints(target, s)).abs().max().item<double>();
  const double before = (posed_joints(start, s) - posed_joints(target, s)).abs().max().item<double>();
  EXPECT_LT(error, 2e-4) << before << " -> " << error;  // 1e-3 at the constant rates
  fitting.translation_learning_rate = 0;
  testing::expect_error([&] { fit_pose(start, s, 1.0, fitting, {}, loss); }, {"learning rate"});
}

TEST(PoseFitting, FitsANoisyPoseToItsImageWithTheAvatarFrozen) {
  auto options = testing::tiny_training("pose_fitting", 150, 1024);
  options.images_per_step = 2;
  options.occupancy_every = 25;
  options.occupancy_warmup = 50;
  options.decay_fraction = 0;
  train_avatar(options);
  auto trained = TrainedAvatar::load(options.out_dir);
  const ImageDataset data(options.data_dir);
  const auto split = data.load_split("train");
  const auto& skeleton = data.character().skeleton;
  const double size = character_size(data.character().mesh.vertices);
  const auto exact = split.bone_transforms[0];
  const auto noisy = testing::noisy_bones(exact, skeleton, size);
  const auto table = trained.avatar->field()->table().clone();

  PoseFittingOptions fitting;
  EXPECT_TRUE(torch::equal(fit_pose_to_image(trained.avatar, split, 0, noisy, data.background(), skeleton, size, fitting),
                           noisy));  // 0 steps: as given
  fitting.steps = 100;
  const auto fitted = fit_pose_to_image(trained.avatar, split, 0, noisy, data.background(), skeleton, size, fitting);
  const auto before = pose_error(noisy.unsqueeze(0), exact.unsqueeze(0), skeleton, size);
  const auto after = pose_error(fitted.unsqueeze(0), exact.unsqueeze(0), skeleton, size);
  EXPECT_LT(after.joint_distance, 0.8 * before.joint_distance) << before.joint_distance << " -> " << after.joint_distance;
  // The fitted pose renders its image better than the noisy one.
  const auto psnr_with = [&](const torch::Tensor& bones) {
    const auto frame = trained.avatar->pose(bones);
    const auto image = trained.avatar->render_image(frame, split.cameras[0], data.background()).first;
    return psnr(image, split.images[0].to(torch::kFloat32) / 255);
  };
  EXPECT_GT(psnr_with(fitted), psnr_with(noisy) + 0.5) << psnr_with(noisy) << " -> " << psnr_with(fitted) << " (exact "
                                                         << psnr_with(exact) << ")";
  // The avatar is unchanged and trainable again.
  EXPECT_TRUE(torch::equal(trained.avatar->field()->table(), table));
  EXPECT_TRUE(trained.avatar->field()->table().requires_grad());
  // Through the evaluation, recorded in its JSON.
  const auto scores = evaluate_avatar_run(options.out_dir, "", "novel_pose", 1, false, {2});
  EXPECT_EQ(scores.pose_fitting_steps, 2);
  EXPECT_NE(scores.to_json().find("\"pose_fitting_steps\": 2"), std::string::npos);
}

TEST(PoseRefinement, ARunWithoutRefinementHasNoRefinedPoses) {
  auto options = testing::tiny_training("pose_refinement_off", 1, 64);
  train_avatar(options);
  EXPECT_THROW(refined_poses(options.out_dir), Error);
}

}  // namespace
}  // namespace fskin
