#pragma once
// PSNR and SSIM of a trained avatar's renders against a split of its image
// dataset (novel views, novel poses), per image and on average.
#include <functional>
#include <string>
#include <vector>

#include "fskin/radiance/avatar.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/pose_fitting.h"

namespace fskin {

struct AvatarFrameScore {
  int64_t index = 0, pose_index = 0, view_index = 0;
  double psnr = 0, ssim = 0, render_seconds = 0;
  // PSNR over the box of the ground-truth mask grown by 10 % (the subject and
  // its surroundings, without most of the background the whole image has).
  double psnr_subject_box = 0;
};

struct AvatarEvaluation {
  std::string split;
  std::vector<AvatarFrameScore> frames;
  double mean_psnr = 0, mean_ssim = 0, mean_psnr_subject_box = 0, median_render_seconds = 0;
  int64_t pose_fitting_steps = 0;  // test-time pose optimisation per image (pose_fitting.h); 0: none
  std::string to_json() const;  // with every frame
  std::string to_table() const;
};

// What image `image` of a split is rendered with: its bones (refined or
// fitted poses) and its appearance code (undefined: the mean appearance).
struct FrameInputs {
  torch::Tensor bones, appearance;
};
// Empty: the split's own bones and the mean appearance.
using FrameInputsOf = std::function<FrameInputs(const ImageSplit& split, int64_t image)>;

// A picture [H, W, 3] in [0, 1] of a frame's inputs seen by a camera on a
// background: what any avatar representation evaluates through.
using FrameRenderer = std::function<torch::Tensor(const FrameInputs& inputs, const PinholeCamera& camera,
                                                  const std::array<double, 3>& background)>;

// Renders every image of `split` (at most max_images, evenly spread; 0 = all)
// on the dataset's background and scores it over the whole image (as the
// avatar papers do) and over the subject's box.
AvatarEvaluation evaluate_renders(const FrameRenderer& render, const ImageDataset& data, const std::string& split,
                                  int64_t max_images = 0, bool progress = true, const FrameInputsOf& inputs_of = {});

// evaluate_renders of a volume avatar.
AvatarEvaluation evaluate_avatar(Avatar& avatar, const ImageDataset& data, const std::string& split,
                                 int64_t max_images = 0, bool progress = true, const FrameInputsOf& inputs_of = {});

// evaluate_avatar for a run directory: its avatar on `data_dir` (empty: the
// dataset it was trained on), the training poses' images with the run's
// refined bones when it refines poses (novel views of training poses, as the
// papers evaluate refined captures) and their frames' appearance codes when
// it learns them (other poses: the mean appearance), and with fitting.steps > 0 every
// image's pose fitted to it first (pose_fitting.h: test-time optimisation).
AvatarEvaluation evaluate_avatar_run(const std::string& run_dir, const std::string& data_dir,
                                     const std::string& split, int64_t max_images = 0, bool progress = true,
                                     const PoseFittingOptions& fitting = {});

}  // namespace fskin
