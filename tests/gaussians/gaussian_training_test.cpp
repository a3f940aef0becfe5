// Training Gaussian avatars: density control's bookkeeping (parameters and
// Adam's moments), a short run that learns the tiny dataset, resume repeating
// an uninterrupted run exactly, and the config document.
#include "fskin/gaussians/gaussian_training.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <fstream>

#include "fskin/engine/run_directory.h"
#include "fskin/gaussians/density_control.h"
#include "fskin/gaussians/gaussian_config.h"
#include "fskin/gaussians/gaussian_evaluation.h"
#include "fskin/gaussians/surface_layer.h"
#include "fskin/radiance/image_metrics.h"
#include "gaussians/tiny_gaussian_training.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

using testing::tiny_gaussian_training;

TEST(GaussianDensityControl, ClonesSplitsAndPrunesWithTheirAdamMoments) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  GaussianAvatarOptions options;
  options.initial_gaussians = 40;
  options.skinning_grid_resolution = 16;
  options.learned_skinning = true;
  options.anchored = true;
  GaussianAvatar avatar(dataset.character(), options, 0);
  const double size = 1.7;
  {
    torch::NoGradGuard no_grad;
    avatar->skinning_corrections().copy_(torch::rand_like(avatar->skinning_corrections()));
    // Gaussians 0-9 small (clone candidates), 10-19 large (split), 20-24 transparent (pruned).
    avatar->log_scales().fill_(std::log(0.005 * size));
    avatar->log_scales().narrow(0, 10, 10).fill_(std::log(0.05 * size));
    avatar->opacity_logits().narrow(0, 20, 5).fill_(-8.0f);
  }
  torch::optim::Adam adam(avatar->parameters(), torch::optim::AdamOptions(1e-3));
  {
    // Its graph is released before the Gaussians change (GaussianAvatarImpl::replace_gaussians).
    torch::Tensor everything = torch::zeros({});
    for (const auto& p : avatar->parameters()) everything = everything + p.sum();
    everything.backward();
  }
  adam.step();  // moments exist for every parameter
  DensityStatistics statistics;
  statistics.reset(40);
  auto grad = torch::zeros({40, 2});
  grad.narrow(0, 0, 20).fill_(1.0f);  // in pixels; x 20 (half of 40 pixels) in NDC units
  statistics.add(grad, torch::ones({40}), 40, 40);
  const auto before_means = avatar->means().detach().clone();
  const auto before_sh = avatar->sh_dc().detach().clone();
  const auto before_weights = avatar->surface_weights().clone();
  const auto before_corrections = avatar->skinning_corrections().detach().clone();
  const auto before_anchors = avatar->surface_anchors().clone();
  DensityControlOptions control;
  const auto change = densify_and_prune(*avatar, statistics, adam, control, size);
  EXPECT_EQ(change.cloned, 10);
  EXPECT_EQ(change.split, 10);
  EXPECT_EQ(change.pruned, 5);
  // 40 - 5 pruned - 10 split parents + 10 clones + 20 halves.
  EXPECT_EQ(avatar->size(), 55);
  // The kept ones first in their order (0-9 and 25-39), then the clones, then the halves.
  const auto kept = torch::cat({torch::arange(0, 10), torch::arange(25, 40)});
  EXPECT_TRUE(torch::equal(avatar->means().narrow(0, 0, 25), before_means.index_select(0, kept)));
  EXPECT_TRUE(torch::equal(avatar->means().narrow(0, 25, 10), before_means.narrow(0, 0, 10)));
  EXPECT_TRUE(torch::equal(avatar->sh_dc().narrow(0, 35, 10), before_sh.narrow(0, 10, 10)));
  // Clones and halves carry their parent's skinning weights.
  ASSERT_EQ(avatar->surface_weights().size(0), 55);
  EXPECT_TRUE(torch::equal(avatar->surface_weights().narrow(0, 0, 25), before_weights.index_select(0, kept)));
  EXPECT_TRUE(torch::equal(avatar->surface_weights().narrow(0, 25, 10), before_weights.narrow(0, 0, 10)));
  EXPECT_TRUE(torch::equal(avatar->surface_weights().narrow(0, 35, 10), before_weights.narrow(0, 10, 10)));
  EXPECT_TRUE(torch::equal(avatar->surface_weights().narrow(0, 45, 10), before_weights.narrow(0, 10, 10)));
  EXPECT_TRUE(torch::equal(avatar->skinning_corrections().narrow(0, 25, 10), before_corrections.narrow(0, 0, 10)));
  EXPECT_TRUE(torch::equal(avatar->skinning_corrections().narrow(0, 45, 10), before_corrections.narrow(0, 10, 10)));
  // ... and its surface anchor.
  ASSERT_EQ(avatar->surface_anchors().sizes(), (std::vector<int64_t>{55, 6}));
  EXPECT_TRUE(torch::equal(avatar->surface_anchors().narrow(0, 0, 25), before_anchors.index_select(0, kept)));
  EXPECT_TRUE(torch::equal(avatar->surface_anchors().narrow(0, 25, 10), before_anchors.narrow(0, 0, 10)));
  EXPECT_TRUE(torch::equal(avatar->surface_anchors().narrow(0, 35, 10), before_anchors.narrow(0, 10, 10)));
  EXPECT_TRUE(torch::equal(avatar->surface_anchors().narrow(0, 45, 10), before_anchors.narrow(0, 10, 10)));
  const auto half_scales = torch::exp(avatar->log_scales().narrow(0, 35, 20));
  // (Adam's one step moved the log-scales by about its learning rate.)
  EXPECT_TRUE(torch::allclose(half_scales, torch::full_like(half_scales, 0.05 * size / 1.6), 2e-3, 0.0));
  // Halves are drawn around their parent, within a few of its standard deviations.
  const auto offset = (avatar->means().narrow(0, 35, 10) - before_means.narrow(0, 10, 10)).norm(2, 1);
  EXPECT_LT(offset.max().item<double>(), 5 * std::sqrt(3.0) * 0.05 * size);
  for (const auto& p : avatar->parameters()) {
    const auto& state = static_cast<torch::optim::AdamParamState&>(
        *adam.state().at(c10::guts::to_string(p.unsafeGetTensorImpl())));
    EXPECT_EQ(state.exp_avg().size(0), 55);
    EXPECT_EQ(state.exp_avg_sq().size(0), 55);
    EXPECT_EQ(state.exp_avg().narrow(0, 25, 30).abs().max().item<double>(), 0.0);  // new Gaussians start at zero
  }
  // The next step trains the new set.
  adam.zero_grad();
  avatar->means().square().sum().backward();
  adam.step();
  EXPECT_EQ(avatar->means().grad().size(0), 55);
}

TEST(GaussianDensityControl, PrunesGaussiansWiderThanSomeInitialSpacings) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  GaussianAvatarOptions options;
  options.initial_gaussians = 30;
  GaussianAvatar avatar(dataset.character(), options, 0);
  const double spacing = avatar->initial_spacing();
  EXPECT_GT(spacing, 0.0);
  {
    torch::NoGradGuard no_grad;  // 0-9 at 2 spacings, 10-29 at 4
    avatar->log_scales().fill_(std::log(4 * spacing));
    avatar->log_scales().narrow(0, 0, 10).fill_(std::log(2 * spacing));
  }
  torch::optim::Adam adam(avatar->parameters(), torch::optim::AdamOptions(1e-3));
  DensityStatistics statistics;
  statistics.reset(30);
  DensityControlOptions control;
  control.max_scale_fraction = 1e3;  // the size's bound out of the way
  control.max_scale_spacings = 3;
  EXPECT_EQ(densify_and_prune(*avatar, statistics, adam, control, 1.0).pruned, 20);
  EXPECT_EQ(avatar->size(), 10);
  control.max_scale_spacings = 0;  // no bound
  statistics.reset(10);
  EXPECT_EQ(densify_and_prune(*avatar, statistics, adam, control, 1.0).pruned, 0);
}

TEST(GaussianTraining, AShortRunLearnsTheTinyDataset) {
  auto options = tiny_gaussian_training("gaussian_short_run", 150);
  const ImageDataset data(options.data_dir);
  const auto split = data.load_split("train");
  // The untrained avatar (grey Gaussians on the canonical mesh) as a baseline.
  GaussianAvatar untrained(data.character(), options.avatar, options.seed);
  double before = 0;
  {
    torch::NoGradGuard no_grad;
    for (int64_t i = 0; i < split.size(); ++i) {
      const auto image = untrained->render(split.bone_transforms[i], split.cameras[i], data.background()).image;
      before += psnr(image.clamp(0, 1), split.images[i].to(torch::kFloat32) / 255) / static_cast<double>(split.size());
    }
  }
  const auto summary = train_gaussian_avatar(options);
  EXPECT_EQ(summary.last_step, 150);
  EXPECT_NE(summary.gaussians, 1500);  // density control ran
  const auto train_scores = evaluate_gaussian_avatar_run(options.out_dir, "", "train", 0, false);
  const auto novel_pose = evaluate_gaussian_avatar_run(options.out_dir, "", "novel_pose", 0, false);
  EXPECT_GT(train_scores.mean_psnr, before + 3.0) << "before " << before;
  EXPECT_GT(novel_pose.mean_psnr, before + 2.0) << "before " << before;
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(options.out_dir) / "gaussian_avatar.json"));
  EXPECT_TRUE(is_gaussian_avatar_run(options.out_dir));
  // The surface layer prior (on by default) trained with it, and its anchors came through density control.
  std::ifstream log(options.out_dir + "/log.jsonl");
  std::string line, last;
  while (std::getline(log, line)) last = line;
  EXPECT_NE(last.find("\"layer\""), std::string::npos) << last;
  const auto trained = TrainedGaussianAvatar::load(options.out_dir);
  ASSERT_TRUE(trained.avatar->options().anchored);
  EXPECT_EQ(trained.avatar->surface_anchors().size(0), trained.avatar->size());
  // 0.012 here; 0.086 with a negligible weight (1e-9).
  EXPECT_LT(surface_layer_spread(*trained.avatar).item<double>(), 0.04);
}

TEST(GaussianTraining, AMonocularDatasetTrainsAndItsHeldOutViewsImprove) {
  // PeopleSnapshot's layout: one camera, the subject turning over 8 poses.
  const auto& tiny = testing::tiny_image_dataset();
  const auto dir = testing::temp_dir("gaussian_monocular");
  auto data_options = testing::tiny_image_options((dir / "data").string());
  data_options.monocular = true;
  const auto poses = make_training_poses(tiny.model.data().joint_names, TrainingPoseOptions{2, 4, 3});
  build_image_dataset(tiny.model, poses, tiny.held_out, data_options);
  auto options = tiny_gaussian_training("gaussian_monocular_run", 150);
  options.data_dir = data_options.out_dir;
  const ImageDataset data(options.data_dir);
  ASSERT_EQ(data.load_split("train").size(), 8);
  const auto novel_view = data.load_split("novel_view");
  ASSERT_GT(novel_view.size(), 0);
  GaussianAvatar untrained(data.character(), options.avatar, options.seed);
  double before = 0;
  {
    torch::NoGradGuard no_grad;
    for (int64_t i = 0; i < novel_view.size(); ++i) {
      const auto image = untrained->render(novel_view.bone_transforms[i], novel_view.cameras[i], data.background()).image;
      before += psnr(image.clamp(0, 1), novel_view.images[i].to(torch::kFloat32) / 255) /
                static_cast<double>(novel_view.size());
    }
  }
  train_gaussian_avatar(options);
  const auto scores = evaluate_gaussian_avatar_run(options.out_dir, "", "novel_view", 0, false);
  EXPECT_GT(scores.mean_psnr, before + 2.0) << "before " << before;
}

TEST(GaussianTraining, AResumedRunRepeatsTheUninterruptedOneExactly) {
  // 60 steps with a checkpoint at 30; the run is then cut back to its
  // step-30 checkpoint, as a kill after it leaves it, and resumed to 60.
  auto options = tiny_gaussian_training("gaussian_resume", 60);
  options.checkpoint_every = 30;
  options.density.stop_fraction = 0.8;  // densifications at 20 and 40, on both sides of the cut
  options.avatar.learned_skinning = true;  // its corrections and their moments resume too
  options.avatar.non_rigid = true;         // and the non-rigid offset's network
  options.data_dir = testing::perturbed_tiny_dataset();
  options.refine_poses = true;  // and the pose corrections (one pass)
  options.pose_first_pass_steps = 0;
  train_gaussian_avatar(options);
  const auto whole = TrainedGaussianAvatar::load(options.out_dir);
  const RunDirectory run(options.out_dir);
  ASSERT_EQ(run.checkpoints().size(), 2u);
  std::filesystem::remove(run.checkpoints().front());  // the step-60 one
  ASSERT_EQ(TrainedGaussianAvatar::load(options.out_dir).step, 30);
  options.resume = true;
  const auto summary = train_gaussian_avatar(options);
  EXPECT_EQ(summary.first_step, 30);
  const auto resumed = TrainedGaussianAvatar::load(options.out_dir);
  EXPECT_EQ(resumed.step, 60);
  EXPECT_NE(whole.avatar->size(), options.avatar.initial_gaussians);
  ASSERT_EQ(whole.avatar->size(), resumed.avatar->size());
  EXPECT_TRUE(torch::equal(whole.avatar->means(), resumed.avatar->means()));
  EXPECT_TRUE(torch::equal(whole.avatar->sh_dc(), resumed.avatar->sh_dc()));
  EXPECT_TRUE(torch::equal(whole.avatar->opacity_logits(), resumed.avatar->opacity_logits()));
  EXPECT_TRUE(torch::equal(whole.avatar->skinning_corrections(), resumed.avatar->skinning_corrections()));
  EXPECT_GT(whole.avatar->skinning_corrections().abs().max().item<double>(), 0.0);  // they were learned
  const auto whole_network = whole.avatar->non_rigid_offset()->parameters();
  const auto resumed_network = resumed.avatar->non_rigid_offset()->parameters();
  ASSERT_EQ(whole_network.size(), resumed_network.size());
  for (size_t k = 0; k < whole_network.size(); ++k) EXPECT_TRUE(torch::equal(whole_network[k], resumed_network[k]));
  EXPECT_GT(whole_network.back().abs().max().item<double>(), 0.0);  // the last layer left zero
  ASSERT_TRUE(whole.corrections && resumed.corrections);
  EXPECT_TRUE(torch::equal(whole.corrections->rotations(), resumed.corrections->rotations()));
  EXPECT_TRUE(torch::equal(whole.corrections->translations(), resumed.corrections->translations()));
  EXPECT_GT(whole.corrections->rotations().abs().max().item<double>(), 0.0);
}

TEST(GaussianTraining, TheConfigDocumentRoundTripsAndNamesBadKeys) {
  GaussianTrainOptions base;
  base.data_dir = "data";
  base.out_dir = "out";
  const auto changed = configure_gaussian_options(base, "", {"model.gaussians.sh_degree=3", "density.every=50"});
  EXPECT_EQ(changed.avatar.sh_degree, 3);
  EXPECT_EQ(changed.density.every, 50);
  const auto again = gaussian_options_from_document(gaussian_config_document(changed), base, "doc");
  EXPECT_EQ(gaussian_config_document(again), gaussian_config_document(changed));
  testing::expect_error([&] { configure_gaussian_options(base, "", {"model.gaussians.colour=3"}); },
                        {"--set model.gaussians.colour=3", "unknown key"});
  testing::expect_error([&] { configure_gaussian_options(base, "", {"model.gaussians.sh_degree=5"}); },
                        {"sh_degree", "0 to 3"});
  testing::expect_error([&] { configure_gaussian_options(base, "", {"model.gaussians.dilation=-0.1"}); },
                        {"dilation must be within 0..10"});
  EXPECT_EQ(base.opacity_weight, 0.0);
  EXPECT_EQ(configure_gaussian_options(base, "", {"losses.opacity.weight=0.01"}).opacity_weight, 0.01);
  testing::expect_error([&] { configure_gaussian_options(base, "", {"losses.opacity.weight=-1"}); },
                        {"losses.opacity.weight must be >= 0"});
  EXPECT_EQ(base.alpha_entropy_weight, 0.0);
  const auto unseen = configure_gaussian_options(base, "", {"losses.alpha_entropy.weight=0.1",
                                                            "losses.unseen_view.degrees=30"});
  EXPECT_EQ(unseen.alpha_entropy_weight, 0.1);
  EXPECT_EQ(unseen.unseen_view_degrees, 30.0);
  testing::expect_error([&] { configure_gaussian_options(base, "", {"losses.alpha_entropy.weight=-1"}); },
                        {"losses.alpha_entropy.weight must be >= 0"});
  testing::expect_error([&] { configure_gaussian_options(base, "", {"losses.unseen_view.degrees=200"}); },
                        {"losses.unseen_view.degrees must be within [0, 180]"});
  EXPECT_EQ(base.unseen_view_every, 4);
  EXPECT_EQ(configure_gaussian_options(base, "", {"losses.unseen_view.every=3"}).unseen_view_every, 3);
  testing::expect_error([&] { configure_gaussian_options(base, "", {"losses.unseen_view.every=0"}); },
                        {"losses.unseen_view.every must be >= 1"});
  EXPECT_EQ(base.rig_silhouette_weight, 0.5);
  EXPECT_EQ(configure_gaussian_options(base, "", {"losses.rig_silhouette.weight=0.25"}).rig_silhouette_weight, 0.25);
  testing::expect_error([&] { configure_gaussian_options(base, "", {"losses.rig_silhouette.weight=-1"}); },
                        {"losses.rig_silhouette.weight must be >= 0"});
  // On a dataset imported from a capture (its mesh a fitted body model) the
  // rig silhouette prior is off unless it is asked for.
  auto capture = base;
  capture.data_dir = testing::temp_dir("gaussian_config_capture").string();
  std::ofstream(std::filesystem::path(capture.data_dir) / "manifest.json") << R"({"capture": "/somewhere"})";
  EXPECT_EQ(configure_gaussian_options(capture, "", {}).rig_silhouette_weight, 0.0);
  EXPECT_EQ(configure_gaussian_options(capture, "", {"losses.rig_silhouette.weight=0.5"}).rig_silhouette_weight, 0.5);
  EXPECT_EQ(configure_gaussian_options(capture, "", {"losses.mask.weight=1"}).rig_silhouette_weight, 0.0);
  EXPECT_EQ(changed.avatar.skinning_source, "surface");
  testing::expect_error([&] { configure_gaussian_options(base, "", {"model.skinning.source=bones"}); },
                        {"--set model.skinning.source=bones", "\"surface\" or \"grid\""});
  // A run file from before the skinning source, the antialiasing and the disc starts existed
  // reads the grid, draws without the compensation and started from spheres, as it was trained.
  const auto dir = testing::temp_dir("gaussian_run_without_source");
  auto old_document = gaussian_run_document(changed);
  old_document["model"]["skinning"].erase("source");
  old_document["model"]["gaussians"].erase("antialiased");
  old_document["model"]["gaussians"].erase("initial_thickness");
  old_document["model"]["gaussians"].erase("dilation");
  old_document["density"].erase("max_scale_spacings");
  old_document["losses"].erase("surface_layer");
  old_document["losses"].erase("rig_silhouette");
  old_document["losses"].erase("unseen_view");
  old_document["losses"]["alpha_entropy"]["degrees"] = 30;
  old_document["pose_refinement"].erase("fit_steps");
  old_document["pose_refinement"].erase("fit_rounds");
  std::ofstream(dir / "run.json") << old_document.dump();
  const auto old = read_gaussian_run_config((dir / "run.json").string(), dir.string()).avatar;
  EXPECT_EQ(old.skinning_source, "grid");
  EXPECT_FALSE(old.antialiased);
  EXPECT_EQ(old.initial_thickness, 1.0);
  EXPECT_EQ(old.dilation, 0.3);  // 3DGS's, before the key
  EXPECT_EQ(changed.avatar.dilation, 0.1);
  EXPECT_EQ(read_gaussian_run_config((dir / "run.json").string(), dir.string()).density.max_scale_spacings, 0.0);
  // ... and without the surface layer prior, whose anchors its checkpoints lack.
  const auto old_options = read_gaussian_run_config((dir / "run.json").string(), dir.string());
  EXPECT_EQ(old_options.layer_weight, 0.0);
  // ... its unseen view's angle kept under the entropy's key, and no rig silhouette prior.
  EXPECT_EQ(old_options.unseen_view_degrees, 30.0);
  EXPECT_EQ(old_options.rig_silhouette_weight, 0.0);
  EXPECT_EQ(old_options.unseen_view_every, 1);
  // ... and its poses refined in two passes, without fitting between them.
  EXPECT_EQ(old_options.pose_fit_steps, 0);
  EXPECT_EQ(old_options.pose_fit_rounds, 1);
  EXPECT_GT(changed.pose_fit_steps, 0);
  EXPECT_EQ(changed.pose_fit_rounds, 2);
  EXPECT_EQ(configure_gaussian_options(base, "", {"pose_refinement.fit_rounds=2"}).pose_fit_rounds, 2);
  testing::expect_error([&] { configure_gaussian_options(base, "", {"pose_refinement.fit_rounds=0"}); },
                        {"pose_refinement.fit_rounds must be >= 1"});
  EXPECT_FALSE(old_options.avatar_options().anchored);
  EXPECT_GT(changed.layer_weight, 0.0);
  EXPECT_TRUE(changed.avatar_options().anchored);
  testing::expect_error([&] { configure_gaussian_options(base, "", {"losses.surface_layer.weight=-1"}); },
                        {"losses.surface_layer.weight must be >= 0"});
  EXPECT_TRUE(changed.avatar.antialiased);
  EXPECT_LT(changed.avatar.initial_thickness, 1.0);
  testing::expect_error([&] { TrainedGaussianAvatar::load(testing::temp_dir("not_a_gaussian_run").string()); },
                        {"not a Gaussian avatar run"});
}

}  // namespace
}  // namespace fskin
