// Pose refinement of Gaussian avatars (gaussian_training.h, refine_poses):
// on the tiny dataset with noisy training poses, the learned corrections bring
// the poses closer to the exact ones, and the run's refined bones are what
// evaluation and rendering use for training poses; the two passes, their stop
// and resume; test-time fitting of one image's pose with the Gaussians frozen.
#include <ATen/Parallel.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/engine/checkpoint.h"
#include "fskin/engine/stop_signal.h"
#include "fskin/engine/run_directory.h"
#include "fskin/engine/trainer.h"
#include "fskin/geometry/character_size.h"
#include "fskin/gaussians/gaussian_evaluation.h"
#include "fskin/gaussians/gaussian_pose_fitting.h"
#include "fskin/gaussians/gaussian_training.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/appearance_codes.h"
#include "fskin/radiance/pose_correction.h"
#include "fskin/radiance/image_metrics.h"
#include "gaussians/tiny_gaussian_training.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// The tiny dataset with noisy training poses, refined in one pass.
GaussianTrainOptions tiny_refinement(const std::string& name, int64_t steps) {
  auto o = testing::tiny_gaussian_training(name, steps);
  o.data_dir = testing::perturbed_tiny_dataset();
  o.refine_poses = true;
  o.pose_first_pass_steps = 0;
  o.pose_fit_rounds = 1;  // the tests that fit twice say so
  return o;
}

// The "gaussians" of a run log's first and last lines.
std::pair<double, double> logged_gaussians(const std::string& log_file) {
  std::ifstream in(log_file);
  std::vector<nlohmann::json> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(nlohmann::json::parse(line));
  if (lines.empty()) return {-1, -1};
  return {lines.front().at("gaussians").get<double>(), lines.back().at("gaussians").get<double>()};
}

TEST(GaussianPoseRefinement, LearnsCorrectionsThatBringThePosesCloserToTheExactOnes) {
  auto options = tiny_refinement("gaussian_pose_refinement", 150);
  options.pose_first_pass_steps = 150;  // the default: two passes
  train_gaussian_avatar(options);
  const auto refined = refined_gaussian_poses(options.out_dir);
  ASSERT_EQ(refined.given.size(0), 3);  // 3 training poses, 2 views each
  ASSERT_TRUE(refined.exact.defined());
  EXPECT_GT(refined.mean_rotation_degrees, 0);
  EXPECT_LT(refined.refined_error.joint_distance, 0.8 * refined.given_error.joint_distance)
      << refined.to_string();
  // The saved file holds the three sets.
  const auto saved = (fs::path(options.out_dir) / "refined.npz").string();
  refined.save(saved);
  EXPECT_TRUE(torch::equal(io::NpzReader(saved).tensor("bone_transforms"), refined.refined));

  // A novel view of a training pose is rendered with its frame's refined
  // bones, a novel pose with its own.
  const auto trained = TrainedGaussianAvatar::load(options.out_dir);
  ASSERT_TRUE(trained.corrections);
  const ImageDataset data(options.data_dir);
  const auto novel_view = data.load_split("novel_view");
  const int64_t frame = trained.corrections->find(novel_view.bone_transforms[0]);
  ASSERT_GE(frame, 0);
  EXPECT_LT((trained.bones_for(novel_view.bone_transforms[0]) - refined.refined[frame]).abs().max().item<double>(), 1e-5);
  const auto novel_pose = data.load_split("novel_pose");
  EXPECT_TRUE(torch::equal(trained.bones_for(novel_pose.bone_transforms[0]), novel_pose.bone_transforms[0]));
  // ... and the evaluation scores those renders: better than the given bones'.
  const auto scores = evaluate_gaussian_avatar_run(options.out_dir, "", "novel_view", 0, false);
  ASSERT_EQ(scores.frames.size(), 2u);
  auto given = TrainedGaussianAvatar::load(options.out_dir);
  given.corrections = nullptr;  // the same Gaussians on the given (noisy) bones
  double given_psnr = 0;
  for (int64_t i = 0; i < novel_view.size(); ++i) {
    const auto image = given.render(novel_view.bone_transforms[i], novel_view.cameras[i], data.background()).first;
    given_psnr += psnr(image, novel_view.images[i].to(torch::kFloat32) / 255) / static_cast<double>(novel_view.size());
  }
  EXPECT_GT(scores.mean_psnr, given_psnr) << "given bones " << given_psnr;
}

TEST(GaussianPoseFitting, FitsANoisyPoseToItsImageWithTheGaussiansFrozen) {
  auto options = tiny_refinement("gaussian_pose_fitting", 200);
  options.data_dir = testing::tiny_image_dataset().dir;  // exact poses
  options.refine_poses = false;
  train_gaussian_avatar(options);
  auto trained = TrainedGaussianAvatar::load(options.out_dir);
  const ImageDataset data(options.data_dir);
  const auto split = data.load_split("train");
  const auto& skeleton = data.character().skeleton;
  const double size = character_size(data.character().mesh.vertices);
  const auto exact = split.bone_transforms[0];
  const auto noisy = testing::noisy_bones(exact, skeleton, size);
  const auto means = trained.avatar->means().clone();

  PoseFittingOptions fitting;
  EXPECT_TRUE(torch::equal(fit_gaussian_pose_to_image(*trained.avatar, split, 0, noisy, data.background(), skeleton,
                                                      size, 0.5, fitting),
                           noisy));  // 0 steps: as given
  fitting.steps = 100;
  const auto fitted =
      fit_gaussian_pose_to_image(*trained.avatar, split, 0, noisy, data.background(), skeleton, size, 0.5, fitting);
  const auto before = pose_error(noisy.unsqueeze(0), exact.unsqueeze(0), skeleton, size);
  const auto after = pose_error(fitted.unsqueeze(0), exact.unsqueeze(0), skeleton, size);
  EXPECT_LT(after.joint_distance, 0.8 * before.joint_distance) << before.joint_distance << " -> " << after.joint_distance;
  const auto psnr_with = [&](const torch::Tensor& bones) {
    return psnr(trained.render(bones, split.cameras[0], data.background()).first,
                split.images[0].to(torch::kFloat32) / 255);
  };
  EXPECT_GT(psnr_with(fitted), psnr_with(noisy) + 0.5) << psnr_with(noisy) << " -> " << psnr_with(fitted) << " (exact "
                                                         << psnr_with(exact) << ")";
  // The Gaussians are unchanged and trainable again.
  EXPECT_TRUE(torch::equal(trained.avatar->means(), means));
  EXPECT_TRUE(trained.avatar->means().requires_grad());
  // Through the evaluation, recorded in its JSON.
  const auto scores = evaluate_gaussian_avatar_run(options.out_dir, "", "novel_pose", 1, false, {2});
  EXPECT_EQ(scores.pose_fitting_steps, 2);

  // Every training pose at once, each fitted to all its views, in place in
  // the learned corrections (what the two passes do between them).
  const auto frame_of = frames_of_images(split.bone_transforms);
  const auto exact_frames = frame_bone_transforms(split.bone_transforms, frame_of);
  std::vector<torch::Tensor> noisy_frames;
  for (int64_t f = 0; f < exact_frames.size(0); ++f)
    noisy_frames.push_back(testing::noisy_bones(exact_frames[f], skeleton, size));
  PoseCorrections corrections(torch::stack(noisy_frames));
  const auto given_error = pose_error(corrections->given_bones(), exact_frames, skeleton, size);
  {
    StopSignal stop;
    StopSignal::request();  // before the first frame: nothing fitted
    EXPECT_FALSE(fit_gaussian_training_poses(*trained.avatar, split, frame_of, *corrections, nullptr,
                                             data.background(), skeleton, size, 0.5, fitting, false, &stop));
    EXPECT_EQ(corrections->rotations().abs().max().item<double>(), 0);
  }
  EXPECT_TRUE(fit_gaussian_training_poses(*trained.avatar, split, frame_of, *corrections, nullptr, data.background(),
                                          skeleton, size, 0.5, fitting, false));
  const auto fitted_error = pose_error(corrections->corrected(skeleton, size), exact_frames, skeleton, size);
  EXPECT_LT(fitted_error.joint_distance, 0.8 * given_error.joint_distance)
      << given_error.joint_distance << " -> " << fitted_error.joint_distance;
  EXPECT_TRUE(torch::equal(trained.avatar->means(), means));
  // Frames fitted side by side, a thread each, end as frames fitted one after
  // another on one thread, to the bit; the Gaussians took no gradient and
  // are trainable again.
  ASSERT_GE(corrections->frames(), 2);
  const int threads = at::get_num_threads();
  const auto fitted_on = [&](int thread_count) {
    at::set_num_threads(thread_count);
    PoseCorrections again(torch::stack(noisy_frames));
    EXPECT_TRUE(fit_gaussian_training_poses(*trained.avatar, split, frame_of, *again, nullptr, data.background(),
                                            skeleton, size, 0.5, fitting, false));
    return again->rotations();
  };
  const auto one_thread = fitted_on(1), two_threads = fitted_on(2);
  at::set_num_threads(threads);
  EXPECT_TRUE(torch::equal(one_thread, two_threads)) << (one_thread - two_threads).abs().max().item<double>();
  EXPECT_GT(two_threads.abs().max().item<double>(), 0);
  EXPECT_FALSE(trained.avatar->means().grad().defined());
  EXPECT_TRUE(trained.avatar->means().requires_grad());
  // Frame numbers that do not match the split are named.
  testing::expect_error([&] {
    fit_gaussian_training_poses(*trained.avatar, split, {0}, *corrections, nullptr, data.background(), skeleton, size,
                                0.5, fitting, false);
  }, {"frame numbers"});
}

TEST(GaussianPoseFitting, RendersEachFrameWithItsAppearanceCode) {
  // Pictures of an avatar with appearance codes, each frame rendered with a
  // code of its own that changes its colours: fitted with the frames' codes,
  // the noisy poses come back to the exact ones; fitted with code zero, the
  // colours disagree and the fit ends farther off.
  const ImageDataset data(testing::tiny_image_dataset().dir);
  auto split = data.load_split("train");
  const auto& skeleton = data.character().skeleton;
  const double size = character_size(data.character().mesh.vertices);
  auto avatar_options = testing::tiny_gaussian_training("gaussian_pose_fitting_codes", 1).avatar;
  avatar_options.appearance.dim = 4;
  torch::manual_seed(0);
  GaussianAvatar avatar(data.character(), avatar_options, 0);
  const auto frame_of = frames_of_images(split.bone_transforms);
  const auto exact = frame_bone_transforms(split.bone_transforms, frame_of);
  AppearanceCodes codes(exact, 4);
  {
    torch::NoGradGuard no_grad;
    // The code's response starts at zero (gaussian_appearance.h): made strong.
    for (auto& p : avatar->appearance()->named_parameters())
      if (p.key() == "out.weight") p.value().normal_(0, 0.5);
    for (int64_t f = 0; f < codes->frames(); ++f) codes->code(f).normal_(0, 1);
    for (int64_t i = 0; i < split.size(); ++i) {
      const auto rendered = avatar->render(split.bone_transforms[i], split.cameras[static_cast<size_t>(i)],
                                           data.background(), codes->code(frame_of[static_cast<size_t>(i)]));
      split.images[i].copy_((rendered.image * 255).round().clamp(0, 255).to(torch::kUInt8));
      split.masks[i].copy_((rendered.alpha * 255).round().clamp(0, 255).to(torch::kUInt8));
    }
  }
  std::vector<torch::Tensor> noisy_frames;
  for (int64_t f = 0; f < exact.size(0); ++f) noisy_frames.push_back(testing::noisy_bones(exact[f], skeleton, size));
  const auto noisy = torch::stack(noisy_frames);
  PoseFittingOptions fitting;
  fitting.steps = 100;
  const auto fitted_error = [&](const AppearanceCodesImpl* appearance) {
    PoseCorrections corrections(noisy);
    EXPECT_TRUE(fit_gaussian_training_poses(*avatar, split, frame_of, *corrections, appearance, data.background(),
                                            skeleton, size, 0.5, fitting, false));
    return pose_error(corrections->corrected(skeleton, size), exact, skeleton, size).joint_distance;
  };
  const double given = pose_error(noisy, exact, skeleton, size).joint_distance;
  const double with_codes = fitted_error(codes.get()), with_code_zero = fitted_error(nullptr);
  EXPECT_LT(with_codes, 0.3 * given) << given << " -> " << with_codes;
  EXPECT_LT(with_codes, 0.7 * with_code_zero) << "with codes " << with_codes << ", with code zero " << with_code_zero;
  // One image the same way.
  const auto one_image_error = [&](const torch::Tensor& code) {
    const auto fitted = fit_gaussian_pose_to_image(*avatar, split, 0, noisy[frame_of[0]], data.background(), skeleton,
                                                   size, 0.5, fitting, code);
    return pose_error(fitted.unsqueeze(0), exact[frame_of[0]].unsqueeze(0), skeleton, size).joint_distance;
  };
  EXPECT_LT(one_image_error(codes->code(frame_of[0])), 0.7 * one_image_error({}));
  // A code per frame, or none.
  PoseCorrections corrections(noisy);
  AppearanceCodes too_few(exact.slice(0, 0, 1), 4);
  testing::expect_error([&] {
    fit_gaussian_training_poses(*avatar, split, frame_of, *corrections, too_few.get(), data.background(), skeleton,
                                size, 0.5, fitting, false);
  }, {"appearance codes for"});
}

TEST(GaussianPoseRefinement, TheRootShiftStepsAtItsOwnRate) {
  auto options = tiny_refinement("gaussian_pose_refinement_rates", 20);
  options.pose_translation_learning_rate = 1e-6;  // against the rotations' 1e-2
  train_gaussian_avatar(options);
  const auto trained = TrainedGaussianAvatar::load(options.out_dir);
  ASSERT_TRUE(trained.corrections);
  EXPECT_DOUBLE_EQ(trained.options.pose_translation_learning_rate, 1e-6);  // kept in the run's document
  // Adam moves a coordinate by about its rate per step: each of 3 frames
  // steps about 7 times in 20 steps.
  EXPECT_LT(trained.corrections->translations().abs().max().item<double>(), 2e-5);
  EXPECT_GT(trained.corrections->rotations().abs().max().item<double>(), 1e-2);
}

TEST(GaussianPoseRefinement, TheSecondPassStartsFreshGaussiansFromTheFirstPassPoses) {
  auto options = tiny_refinement("gaussian_pose_two_passes", 20);
  options.pose_first_pass_steps = 40;
  options.pose_fit_steps = 0;  // two passes, without fitting between them
  options.pose_second_pass_learning_rate = 1e-9;  // the second pass keeps the first's poses
  const RunDirectory run(options.out_dir), pose_pass(run.pose_pass_directory());
  {
    // Stopped (Ctrl-C) in the first pass: its checkpoint is kept, the second has not begun.
    StopSignal stop;
    options.stop = &stop;
    StopSignal::request();
    const auto stopped = train_gaussian_avatar(options);
    EXPECT_TRUE(stopped.stopped);
    EXPECT_EQ(stopped.pose_pass_last_step, 0);
    EXPECT_EQ(pose_pass.checkpoints().size(), 1u);
    EXPECT_TRUE(run.checkpoints().empty());
    testing::expect_error([&] { TrainedGaussianAvatar::load(options.out_dir); },
                          {options.out_dir, "stopped in a pass of pose refinement", "--resume"});
    options.stop = nullptr;
  }
  options.resume = true;
  const auto summary = train_gaussian_avatar(options);
  EXPECT_FALSE(summary.stopped);
  EXPECT_EQ(summary.pose_pass_first_step, 0);
  EXPECT_EQ(summary.pose_pass_last_step, 40);
  EXPECT_EQ(summary.first_step, 0);
  EXPECT_EQ(summary.last_step, 20);
  // The first pass densified its Gaussians; the second started from the rig's mesh again.
  const auto [first_pass_start, first_pass_end] = logged_gaussians(pose_pass.log_file());
  const double second_pass_start = logged_gaussians(run.log_file()).first;
  EXPECT_NE(first_pass_end, first_pass_start);
  EXPECT_EQ(second_pass_start, first_pass_start);
  // The poses are the first pass's (the second steps them at 1e-9): corrected towards the exact ones.
  const auto refined = refined_gaussian_poses(options.out_dir);
  EXPECT_LT(refined.refined_error.joint_distance, 0.9 * refined.given_error.joint_distance) << refined.to_string();
  const auto after_two = TrainedGaussianAvatar::load(options.out_dir).corrections->rotations();

  // Resumed further, only the second pass runs (its poses come from its checkpoint).
  options.steps = 25;
  const auto more = train_gaussian_avatar(options);
  EXPECT_EQ(more.pose_pass_last_step, more.pose_pass_first_step);
  EXPECT_EQ(more.first_step, 20);
  EXPECT_EQ(more.last_step, 25);
  EXPECT_LT((TrainedGaussianAvatar::load(options.out_dir).corrections->rotations() - after_two).abs().max().item<double>(),
            1e-6);

  auto bad = options;
  bad.pose_first_pass_steps = -1;
  testing::expect_error([&] { bad.validate(); }, {"pose_refinement.first_pass_steps must be >= 0"});
  bad = options;
  bad.pose_fit_steps = -1;
  testing::expect_error([&] { bad.validate(); }, {"pose_refinement.fit_steps must be >= 0"});
}

TEST(GaussianPoseRefinement, WithFittingAThirdPassLearnsFreshGaussiansOnTheFittedPosesKeptAsTheyAre) {
  // Passes long enough for Gaussians that the poses can be fitted to.
  auto options = tiny_refinement("gaussian_pose_three_passes", 100);
  options.pose_first_pass_steps = 100;
  options.pose_fit_steps = 30;
  const RunDirectory run(options.out_dir);
  const auto summary = train_gaussian_avatar(options);
  EXPECT_FALSE(summary.stopped);
  EXPECT_EQ(summary.pose_pass_last_step, 100);
  EXPECT_EQ(summary.last_step, 100);
  // The second pass has a directory of its own, with the run's steps.
  const RunDirectory second(run.pose_pass_directory(2));
  EXPECT_EQ(fs::path(second.path()).filename(), "pose_pass_2");
  ASSERT_EQ(second.checkpoints().size(), 1u);
  EXPECT_NE(second.checkpoints()[0].find("100"), std::string::npos) << second.checkpoints()[0];
  // The fitted poses: closer to the exact ones than the given, zero-mean.
  const auto refined = refined_gaussian_poses(options.out_dir);
  EXPECT_LT(refined.refined_error.joint_distance, 0.8 * refined.given_error.joint_distance) << refined.to_string();
  const auto fitted = TrainedGaussianAvatar::load(options.out_dir).corrections->rotations();
  EXPECT_LT(fitted.mean(0).abs().max().item<double>(), 1e-6);
  // The last pass keeps them as they are: resumed further, at the second
  // pass's rate (1e-3, which moves them in the two-pass flow), they stay.
  options.resume = true;
  options.steps = 110;
  train_gaussian_avatar(options);
  EXPECT_TRUE(torch::equal(TrainedGaussianAvatar::load(options.out_dir).corrections->rotations(), fitted));
}

TEST(GaussianPoseRefinement, WithAppearanceCodesTheTrainingFitUsesThePassCodes) {
  // The fit between the passes is given the second pass's codes
  // (GaussianPoseFitting.RendersEachFrameWithItsAppearanceCode shows what
  // they change); here the run's flow with them: it fits once and completes,
  // a code per pose.
  auto options = tiny_refinement("gaussian_pose_fit_codes", 30);
  options.pose_first_pass_steps = 30;
  options.pose_fit_steps = 5;
  options.avatar.appearance.dim = 4;
  const auto summary = train_gaussian_avatar(options);
  EXPECT_FALSE(summary.stopped);
  EXPECT_EQ(summary.pose_fits, 1);
  const auto trained = TrainedGaussianAvatar::load(options.out_dir);
  ASSERT_TRUE(trained.appearance);
  EXPECT_EQ(trained.appearance->frames(), trained.corrections->frames());
}

TEST(GaussianPoseRefinement, ASecondRoundFitsThePosesAgainAfterAPassOnTheFirstFit) {
  auto options = tiny_refinement("gaussian_pose_two_rounds", 100);
  options.pose_first_pass_steps = 100;
  options.pose_fit_steps = 30;
  options.pose_fit_rounds = 2;
  const RunDirectory run(options.out_dir), third(run.pose_pass_directory(3));
  const auto summary = train_gaussian_avatar(options);
  EXPECT_FALSE(summary.stopped);
  EXPECT_EQ(summary.last_step, 100);
  // The first round's pass has a directory of its own, started from fresh Gaussians.
  EXPECT_EQ(fs::path(third.path()).filename(), "pose_pass_3");
  ASSERT_EQ(third.checkpoints().size(), 1u);
  EXPECT_EQ(logged_gaussians(third.log_file()).first, logged_gaussians(run.log_file()).first);
  const auto refined = refined_gaussian_poses(options.out_dir);
  EXPECT_LT(refined.refined_error.joint_distance, 0.8 * refined.given_error.joint_distance) << refined.to_string();
  const auto twice = TrainedGaussianAvatar::load(options.out_dir).corrections->rotations();
  EXPECT_LT(twice.mean(0).abs().max().item<double>(), 1e-6);

  // The first round's fitted poses, kept by its pass (read from its
  // checkpoint): the second round's fit moved them.
  torch::Tensor fitted_once;
  load_model_checkpoint(third, CheckpointChoice{}, "gaussian_avatar", [&](torch::serialize::InputArchive& archive) {
    auto poses = checkpoint_part(archive, "pose_corrections", third.path(), "refines poses");
    fitted_once = PoseCorrectionsImpl::read(poses)->rotations();
  });
  EXPECT_LT(fitted_once.mean(0).abs().max().item<double>(), 1e-6);
  EXPECT_GT((twice - fitted_once).abs().max().item<double>(), 1e-5);
  EXPECT_EQ(summary.pose_fits, 2);

  // Resumed with the last pass not begun (its checkpoints gone), only the
  // second fit runs again: the third pass's checkpoint holds the first's poses.
  for (const auto& checkpoint : run.checkpoints()) fs::remove(checkpoint);
  fs::remove(run.log_file());
  options.resume = true;
  const auto resumed = train_gaussian_avatar(options);
  EXPECT_EQ(resumed.pose_fits, 1);
  EXPECT_EQ(resumed.last_step, 100);

  auto bad = options;
  bad.pose_fit_rounds = 0;
  testing::expect_error([&] { bad.validate(); }, {"pose_refinement.fit_rounds must be >= 1"});
}

TEST(GaussianPoseRefinement, ARunWithoutRefinementHasNoRefinedPoses) {
  auto options = tiny_refinement("gaussian_pose_refinement_off", 1);
  options.refine_poses = false;
  train_gaussian_avatar(options);
  testing::expect_error([&] { refined_gaussian_poses(options.out_dir); }, {"does not refine poses"});
  EXPECT_FALSE(TrainedGaussianAvatar::load(options.out_dir).corrections);
}

}  // namespace
}  // namespace fskin
