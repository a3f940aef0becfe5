#pragma once
// The Gaussian avatar tests' short training on the tiny image dataset
// (radiance/tiny_image_dataset.h): 1,500 Gaussians, density control every 20
// steps from step 20, no opacity reset, quiet.
#include <string>

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

}  // namespace fskin::testing
