// fskin data build: posed-scan datasets (points + ground-truth occupancy per frame).
// fskin data stick: the 2D stick toy set of SNARF sec. 4.1 in the same layout.
#include <torch/torch.h>

#include <cstdio>

#include "cli/commands.h"
#include "fskin/body/body_model.h"
#include "fskin/data/dataset_builder.h"
#include "fskin/benchmarking/stick2d.h"
#include "fskin/radiance/capture_import.h"
#include "fskin/radiance/pose_perturbation.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/image_dataset_builder.h"

namespace fskin::cli {

void register_data(CLI::App& app) {
  struct Options {
    std::string model, poses, ood_poses, out, canonical = "default";
    int64_t points = 200000;
    uint64_t seed = 0;
    double val_fraction = 0.1, test_fraction = 0.1;
    double thin_surface_share = DatasetBuildOptions{}.thin_surface_share,
           thin_thickness = DatasetBuildOptions{}.thin_thickness;
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
  build->add_option("--canonical-pose", opt->canonical,
                    "canonical pose: default (the model's declared one, else SMPL's Da-pose for SMPL "
                    "skeletons, else the rest pose), da or rest")
      ->check(CLI::IsMember({"default", "da", "rest"}));
  build->add_option("--val-fraction", opt->val_fraction, "fraction of the poses for validation");
  build->add_option("--test-fraction", opt->test_fraction,
                    "fraction of the poses for the within-distribution test");
  build->add_option("--thin-surface-share", opt->thin_surface_share,
                    "share of the training frames' near-surface points drawn on parts thinner than "
                    "--thin-thickness (0: area-uniform; test frames always are)")
      ->check(CLI::Range(0.0, 1.0));
  build->add_option("--thin-thickness", opt->thin_thickness,
                    "thickness below which a part is thin, as a fraction of the character's size")
      ->check(CLI::Range(1e-6, 1.0));
  build->add_flag("--quiet", opt->quiet, "no progress bar");
  build->callback([opt] {
    const auto model = BodyModel::load(opt->model);
    const auto poses = PoseSet::load(opt->poses);
    const auto ood = opt->ood_poses.empty() ? PoseSet{} : PoseSet::load(opt->ood_poses);
    DatasetBuildOptions options;
    options.out_dir = opt->out;
    options.model_source = std::filesystem::absolute(opt->model).string();
    options.poses_source = opt->poses;
    options.ood_poses_source = opt->ood_poses;
    options.sampling.uniform_points = opt->points / 2;
    options.sampling.surface_points = opt->points - opt->points / 2;
    options.seed = opt->seed;
    options.val_fraction = opt->val_fraction;
    options.test_fraction = opt->test_fraction;
    options.canonical_pose = opt->canonical;
    options.thin_surface_share = opt->thin_surface_share;
    options.thin_thickness = opt->thin_thickness;
    options.progress = !opt->quiet;
    const auto summary = build_dataset(model, poses, ood, options);
    std::printf("%s: %s\n", opt->out.c_str(), summary.to_string().c_str());
  });

  struct ImagesOptions {
    std::string model, poses, held_out_poses;
    ImageDatasetOptions dataset;
    std::vector<double> light;
    int size = 0;
    bool quiet = false;
  };
  auto images_opt = std::make_shared<ImagesOptions>();
  auto* images = cmd->add_subcommand(
      "images", "Render a model, textured (SurfaceTexture), in posed frames into an image dataset: cameras.npz, "
                "images, masks and bone transforms per split (train, novel_view, novel_pose); resumable");
  images->add_option("--model", images_opt->model, "SMPL-format model .npz")->required();
  images->add_option("--poses", images_opt->poses, "training pose file .npz (train and novel_view)")->required();
  images->add_option("--held-out-poses", images_opt->held_out_poses, "pose file .npz of the novel_pose split");
  images->add_option("--out", images_opt->dataset.out_dir, "output directory")->required();
  images->add_option("--size", images_opt->size, "width and height in pixels")->check(CLI::Range(8, 4096));
  images->add_option("--width", images_opt->dataset.width, "image width")->check(CLI::Range(8, 4096));
  images->add_option("--height", images_opt->dataset.height, "image height")->check(CLI::Range(8, 4096));
  images->add_option("--views", images_opt->dataset.training_views, "training cameras on a ring around the subject")
      ->check(CLI::Range(1, 64));
  images->add_option("--held-out-views", images_opt->dataset.held_out_views,
                     "held-out cameras, between the training ones")
      ->check(CLI::Range(1, 64));
  images->add_flag("--monocular", images_opt->dataset.monocular,
                   "one training camera, the subject turning once about +Y over the training poses");
  images->add_option("--novel-view-frames", images_opt->dataset.novel_view_frames,
                     "training poses rendered from the held-out views")
      ->check(CLI::NonNegativeNumber);
  images->add_option("--supersampling", images_opt->dataset.supersampling, "s x s samples per pixel")
      ->check(CLI::Range(1, 8));
  images->add_option("--canonical-pose", images_opt->dataset.canonical_pose, "canonical pose: default, da or rest")
      ->check(CLI::IsMember({"default", "da", "rest"}));
  images->add_flag("--black-background", [images_opt](int64_t) { images_opt->dataset.background = {0, 0, 0}; },
                   "black instead of white background");
  images->add_option("--light", images_opt->light,
                     "X,Y,Z: Lambert-shade the texture by a distant light from this direction (world space; default "
                     "unlit)")
      ->expected(3)
      ->delimiter(',');
  images->add_option("--ambient", images_opt->dataset.ambient, "the shaded colour's ambient share, with --light")
      ->check(CLI::Range(0.0, 1.0));
  images->add_option("--light-change", images_opt->dataset.light_change,
                     "light that changes from frame to frame: each training pose's colours scaled per channel by "
                     "factors drawn from [1 - X, 1 + X] (its novel views too; novel poses unchanged); default 0")
      ->check(CLI::Range(0.0, 0.99));
  images->add_option("--texture", images_opt->dataset.texture,
                     "plain (colours, patterns, seams; default) or photographic (with grain, a gradient along the "
                     "body and lines of print on top)")
      ->check(CLI::IsMember({"plain", "photographic"}));
  images->add_flag("--quiet", images_opt->quiet, "no progress bar");
  images->callback([images_opt] {
    auto options = images_opt->dataset;
    if (!images_opt->light.empty()) options.light = {images_opt->light[0], images_opt->light[1], images_opt->light[2]};
    if (images_opt->size > 0) options.width = options.height = images_opt->size;
    const auto model = BodyModel::load(images_opt->model);
    const auto poses = PoseSet::load(images_opt->poses);
    const auto held_out = images_opt->held_out_poses.empty() ? PoseSet{} : PoseSet::load(images_opt->held_out_poses);
    options.model_source = std::filesystem::absolute(images_opt->model).string();
    options.poses_source = images_opt->poses;
    options.ood_poses_source = images_opt->held_out_poses;
    options.progress = !images_opt->quiet;
    const auto summary = build_image_dataset(model, poses, held_out, options);
    std::printf("%s: %s\n", options.out_dir.c_str(), summary.to_string().c_str());
  });

  struct CaptureCommandOptions {
    CaptureImportOptions capture;
    bool black_background = false, quiet = false;
  };
  auto capture_opt = std::make_shared<CaptureCommandOptions>();
  auto* capture = cmd->add_subcommand(
      "capture", "Convert a capture in InstantAvatar's PeopleSnapshot layout (cameras.npz, images/, masks/*.npy or "
                 ".png, poses.npz with SMPL parameters) into an image dataset, with your SMPL-family model; resumable");
  capture->add_option("--capture", capture_opt->capture.capture_dir, "capture directory")->required();
  capture->add_option("--model", capture_opt->capture.model_path, "the SMPL-family model .npz the poses were fitted with")
      ->required()
      ->check(CLI::ExistingFile);
  capture->add_option("--out", capture_opt->capture.out_dir, "output directory")->required();
  capture->add_option("--train", capture_opt->capture.train, "frames of the train split, start:stop:step (default 0:, all)");
  capture->add_option("--novel-pose", capture_opt->capture.novel_pose,
                      "frames of the novel_pose (test) split, start:stop:step");
  capture->add_option("--train-poses", capture_opt->capture.train_poses,
                      "pose file aligned with the train frames (InstantAvatar's poses/anim_nerf_train.npz); default: "
                      "the capture's poses.npz by frame")
      ->check(CLI::ExistingFile);
  capture->add_option("--novel-pose-poses", capture_opt->capture.novel_pose_poses,
                      "pose file aligned with the novel_pose frames (e.g. poses/anim_nerf_test.npz)")
      ->check(CLI::ExistingFile);
  capture->add_option("--canonical-pose", capture_opt->capture.canonical_pose, "canonical pose: default, da or rest")
      ->check(CLI::IsMember({"default", "da", "rest"}));
  capture->add_flag("--black-background", capture_opt->black_background,
                    "composite the photographs over black instead of white");
  capture->add_flag("--quiet", capture_opt->quiet, "no progress bar");
  capture->callback([capture_opt] {
    auto options = capture_opt->capture;
    if (capture_opt->black_background) options.background = {0, 0, 0};
    options.progress = !capture_opt->quiet;
    const auto summary = import_capture(options);
    std::printf("%s: %s\n", options.out_dir.c_str(), summary.to_string().c_str());
  });

  auto perturb = std::make_shared<PosePerturbationOptions>();
  auto* perturb_cmd = cmd->add_subcommand(
      "perturb-poses", "Copy an image dataset with noise on its train and novel_view poses, as a fitted capture has "
                       "(the exact poses stay in each poses.npz as bone_transforms_exact)");
  perturb_cmd->add_option("--data", perturb->data_dir, "image dataset directory")->required()->check(CLI::ExistingDirectory);
  perturb_cmd->add_option("--out", perturb->out_dir, "output directory (new or empty)")->required();
  perturb_cmd->add_option("--degrees", perturb->degrees, "rotation per joint, about a random axis")
      ->check(CLI::Range(0.0, 90.0));
  perturb_cmd->add_option("--translation", perturb->translation,
                          "root shift in a random direction, as a fraction of the character's size")
      ->check(CLI::Range(0.0, 1.0));
  perturb_cmd->add_option("--seed", perturb->seed, "random seed");
  perturb_cmd->callback([perturb] {
    const auto summary = perturb_image_dataset_poses(*perturb);
    std::printf("%s: %s\n", perturb->out_dir.c_str(), summary.to_string().c_str());
  });

  auto stick_opt = std::make_shared<StickDatasetOptions>();
  auto stick = std::make_shared<StickOptions>();
  auto* stick_cmd = cmd->add_subcommand(
      "stick", "The 2D stick toy set (SNARF sec. 4.1): training angles in [-60, 60] degrees, "
               "test_ood in [-120, -60] U [60, 120]");
  stick_cmd->add_option("--out", stick_opt->out_dir, "output directory")->required();
  stick_cmd->add_flag("--object", stick->with_object,
                      "add the separate rigid object the stick can cross (topology change)");
  stick_cmd->add_option("--train", stick_opt->train, "training frames")->check(CLI::PositiveNumber);
  stick_cmd->add_option("--val", stick_opt->val, "validation frames")->check(CLI::NonNegativeNumber);
  stick_cmd->add_option("--test", stick_opt->test_within, "test frames within the training angles")
      ->check(CLI::NonNegativeNumber);
  stick_cmd->add_option("--ood", stick_opt->test_ood, "extrapolation test frames")
      ->check(CLI::NonNegativeNumber);
  stick_cmd->add_option("--points", stick_opt->points_per_frame,
                        "points per frame (half uniform, half near the outline)")
      ->check(CLI::Range(int64_t{2}, int64_t{10000000}));
  stick_cmd->add_option("--seed", stick_opt->seed, "random seed");
  stick_cmd->add_flag("--quiet", [stick_opt](int64_t) { stick_opt->progress = false; },
                      "no progress bar");
  stick_cmd->callback([stick_opt, stick] {
    const auto frames = build_stick_dataset(*stick, *stick_opt);
    std::printf("%s: %lld stick frames written (train %lld, val %lld, test_within %lld, "
                "test_ood %lld), %lld points each\n",
                stick_opt->out_dir.c_str(), static_cast<long long>(frames),
                static_cast<long long>(stick_opt->train), static_cast<long long>(stick_opt->val),
                static_cast<long long>(stick_opt->test_within),
                static_cast<long long>(stick_opt->test_ood),
                static_cast<long long>(stick_opt->points_per_frame));
  });
}

}  // namespace fskin::cli
