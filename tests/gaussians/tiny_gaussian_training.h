#pragma once
// The Gaussian avatar tests' short training on the tiny image dataset
// (radiance/tiny_image_dataset.h): 1,500 Gaussians, density control every 20
// steps from step 20, no opacity reset, quiet.
#include <torch/torch.h>

#include <functional>
#include <string>

#include "fskin/gaussians/gaussian_evaluation.h"
#include "fskin/gaussians/gaussian_training.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin::testing {

inline GaussianTrainOptions tiny_gaussian_training(const std::string& name, int64_t steps) {
  GaussianTrainOptions o;
  o.data_dir = tiny_image_dataset().dir;
  o.out_dir = (temp_dir(name) / "run").string();
  o.steps = steps;
  o.avatar.initial_gaussians = 1500;
  o.avatar.skinning_grid_resolution = 32;
  o.density.start = 20;
  o.density.every = 20;
  o.density.opacity_reset_every = 0;
  o.checkpoint_every = 1000;
  o.log_every = 10;
  o.progress = false;
  return o;
}

// The mean over the tiny dataset's novel_view images of statistic(alpha [H, W],
// mask [H, W] in [0, 1]), alpha the trained run's picture of the image.
inline double mean_over_held_out_views(
    const std::string& run, const std::function<double(const torch::Tensor&, const torch::Tensor&)>& statistic) {
  auto trained = TrainedGaussianAvatar::load(run);
  const ImageDataset data(tiny_image_dataset().dir);
  const auto split = data.load_split("novel_view");
  torch::NoGradGuard no_grad;
  double total = 0;
  for (int64_t i = 0; i < split.size(); ++i) {
    const auto alpha = trained.render(split.bone_transforms[i], split.cameras[i], data.background()).second;
    total += statistic(alpha, split.masks[i].to(torch::kFloat32) / 255);
  }
  return total / static_cast<double>(split.size());
}

}  // namespace fskin::testing
