#pragma once
// PSNR and SSIM of a trained avatar's renders against a split of its image
// dataset (novel views, novel poses), per image and on average.
#include <string>
#include <vector>

#include "fskin/radiance/avatar.h"

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
  std::string to_json() const;  // with every frame
  std::string to_table() const;
};

// Renders every image of `split` (at most max_images, evenly spread; 0 = all)
// on the dataset's background and scores it over the whole image (as the
// avatar papers do) and over the subject's box.
AvatarEvaluation evaluate_avatar(Avatar& avatar, const ImageDataset& data, const std::string& split,
                                 int64_t max_images = 0, bool progress = true);

}  // namespace fskin
