#pragma once
// PSNR and SSIM of a trained Gaussian avatar's renders against a split of an
// image dataset, scored as the volume avatar's are
// (radiance/avatar_evaluation.h: whole image and the subject's box).
#include <cstdint>
#include <string>

#include "fskin/gaussians/gaussian_baking.h"
#include "fskin/radiance/avatar_evaluation.h"
#include "fskin/radiance/pose_fitting.h"

namespace fskin {

// The run's avatar on `data_dir` (empty: the dataset it was trained on);
// with pose refinement, the training poses' images with their refined bones;
// with fitting.steps > 0, every image's pose fitted to it first
// (gaussian_pose_fitting.h: test-time optimisation).
AvatarEvaluation evaluate_gaussian_avatar_run(const std::string& run_dir, const std::string& data_dir,
                                              const std::string& split, int64_t max_images = 0, bool progress = true,
                                              const PoseFittingOptions& fitting = {});

// The same scores for the mesh `fskin avatar export RUN --mesh` writes
// (gaussian_baking.h): the character's subdivided mesh with the colours baked
// from the Gaussians (8-bit, as in the file), posed by linear blend skinning
// with its weights and drawn by fskin's mesh rasteriser (export/render.h,
// 3 x 3 samples per pixel, the colours interpolated across faces, unlit).
// Training poses' images use the run's refined bones, as above.
AvatarEvaluation evaluate_baked_gaussian_mesh(const std::string& run_dir, const std::string& data_dir,
                                              const std::string& split, int64_t max_images = 0, bool progress = true,
                                              const GaussianBakingOptions& baking = {});

}  // namespace fskin
