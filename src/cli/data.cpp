// fskin data build: posed-scan datasets (points + ground-truth occupancy per frame).
#include <torch/torch.h>

#include <cstdio>

#include "cli/commands.h"
#include "fskin/body/body_model.h"
#include "fskin/data/dataset_builder.h"

namespace fskin::cli {

void register_data(CLI::App& app) {
  struct Options {
    std::string model, poses, ood_poses, out, canonical = "da";
    int64_t points = 200000;
    uint64_t seed = 0;
    double val_fraction = 0.1, test_fraction = 0.1;
    bool quiet = false;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("data", "Datasets of posed meshes with ground-truth occupancy");
  cmd->require_subcommand(1);
  auto* build = cmd->add_subcommand(
      "build",
      "Pose a model with a pose set, sample points per frame (half uniform in the box, half near "
      "the surface) and label them inside/outside; resumable and deterministic");
  build->add_option("--model", opt->model, "SMPL-format model .npz")->required();
  build->add_option("--poses", opt->poses, "training pose file .npz (split into train/val/test_within)")
      ->required();
  build->add_option("--out", opt->out, "output directory")->required();
  build->add_option("--ood-poses", opt->ood_poses, "out-of-distribution pose file .npz (test_ood)");
  build->add_option("--points", opt->points, "points per frame (half uniform, half near-surface)")
      ->check(CLI::Range(int64_t{2}, int64_t{100000000}));
  build->add_option("--seed", opt->seed, "random seed of the sampling");
  build->add_option("--canonical-pose", opt->canonical, "canonical pose: da or rest")
      ->check(CLI::IsMember({"da", "rest"}));
  build->add_option("--val-fraction", opt->val_fraction, "fraction of the poses for validation");
  build->add_option("--test-fraction", opt->test_fraction,
                    "fraction of the poses for the within-distribution test");
  build->add_flag("--quiet", opt->quiet, "no progress bar");
  build->callback([opt] {
    const auto model = BodyModel::load(opt->model);
    const auto poses = PoseSet::load(opt->poses);
    const auto ood = opt->ood_poses.empty() ? PoseSet{} : PoseSet::load(opt->ood_poses);
    DatasetBuildOptions options;
    options.out_dir = opt->out;
    options.model_source = opt->model;
    options.poses_source = opt->poses;
    options.ood_poses_source = opt->ood_poses;
    options.sampling.uniform_points = opt->points / 2;
    options.sampling.surface_points = opt->points - opt->points / 2;
    options.seed = opt->seed;
    options.val_fraction = opt->val_fraction;
    options.test_fraction = opt->test_fraction;
    options.canonical_pose = opt->canonical;
    options.progress = !opt->quiet;
    const auto summary = build_dataset(model, poses, ood, options);
    std::printf("%s: %s\n", opt->out.c_str(), summary.to_string().c_str());
  });
}

}  // namespace fskin::cli
