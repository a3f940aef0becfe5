#pragma once
// A small image dataset of the built-in character shared by the radiance
// tests: 3 training poses x 2 views, 2 novel-view and 2 novel-pose images at
// 40 x 40 pixels, built once per test process; a small avatar and its
// training options on it.
#include <torch/torch.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "fskin/body/character.h"
#include "fskin/data/pose_generators.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/image_dataset_builder.h"
#include "fskin/radiance/pose_correction.h"
#include "fskin/radiance/pose_perturbation.h"
#include "fskin/radiance/radiance_field.h"
#include "test_util.h"

namespace fskin::testing {

struct TinyImageDataset {
  BodyModel model;
  PoseSet poses, held_out;
  ImageDatasetOptions options;
  std::string dir;
};

inline ImageDatasetOptions tiny_image_options(const std::string& dir) {
  ImageDatasetOptions options;
  options.out_dir = dir;
  options.width = options.height = 40;
  options.supersampling = 2;
  options.training_views = 2;
  options.held_out_views = 2;
  options.novel_view_frames = 2;
  options.progress = false;
  return options;
}

inline const TinyImageDataset& tiny_image_dataset() {
  static const TinyImageDataset* data = [] {
    CharacterOptions character;
    character.resolution = 40;
    auto* d = new TinyImageDataset{make_character_model(character), {}, {}, {}, {}};
    d->poses = make_training_poses(d->model.data().joint_names, TrainingPoseOptions{1, 3, 0});
    d->held_out = make_ood_poses(d->model.data().joint_names, OodPoseOptions{2, 1});
    d->dir = temp_dir("tiny_image_dataset").string();
    d->options = tiny_image_options(d->dir);
    build_image_dataset(d->model, d->poses, d->held_out, d->options);
    return d;
  }();
  return *data;
}

// The tiny dataset with its train and novel_view poses perturbed (5 degrees
// per joint, 1 % of the size at the root; radiance/pose_perturbation.h), made
// once per process.
inline const std::string& perturbed_tiny_dataset() {
  static const std::string dir = [] {
    PosePerturbationOptions options;
    options.data_dir = tiny_image_dataset().dir;
    options.out_dir = (temp_dir("perturbed_tiny") / "data").string();
    perturb_image_dataset_poses(options);
    return options.out_dir;
  }();
  return dir;
}

// Bones [J, 4, 4] with a pose's noise added (pose_correction.h): at every
// joint 5 degrees about a random axis (seed 3), the root shifted by 1 % of
// the size along x.
inline torch::Tensor noisy_bones(const torch::Tensor& bones, const Skeleton& skeleton, double size) {
  torch::manual_seed(3);
  const auto axes = torch::randn({skeleton.num_joints(), 3});
  const auto noise = axes / axes.norm(2, 1, true) * static_cast<float>(5 * M_PI / 180);
  return corrected_bone_transforms(bones, noise, torch::tensor({0.01f, 0.0f, 0.0f}), skeleton, size);
}

// A small radiance field over the box [-1, 1]^3 with `options`' shading and
// appearance settings (4 hash levels of 2^10 rows, 16 hidden units).
inline RadianceField small_radiance_field(RadianceFieldOptions options) {
  options.encoding.levels = 4;
  options.encoding.log2_table_size = 10;
  options.hidden_dim = 16;
  return RadianceField(options, std::array<double, 3>{-1, -1, -1}, std::array<double, 3>{1, 1, 1});
}

inline AvatarOptions small_avatar() {
  AvatarOptions o;
  o.field.encoding.levels = 8;
  o.field.encoding.log2_table_size = 14;
  o.field.hidden_dim = 32;
  o.skinning_grid_resolution = 32;
  o.canonical_grid_resolution = 32;
  o.posed_grid_resolution = 32;
  return o;
}

// Training options on the tiny dataset into a fresh run directory `name`/run.
inline AvatarTrainOptions tiny_training(const std::string& name, int64_t steps, int64_t rays) {
  AvatarTrainOptions options;
  options.data_dir = tiny_image_dataset().dir;
  options.out_dir = (temp_dir(name) / "run").string();
  options.avatar = small_avatar();
  options.steps = steps;
  options.rays_per_step = rays;
  options.progress = false;
  return options;
}

}  // namespace fskin::testing
