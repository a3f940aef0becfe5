#pragma once
// PSNR and SSIM of a trained Gaussian avatar's renders against a split of an
// image dataset, scored as the volume avatar's are
// (radiance/avatar_evaluation.h: whole image and the subject's box).
#include <cstdint>
#include <string>

#include "fskin/radiance/avatar_evaluation.h"

namespace fskin {

// The run's avatar on `data_dir` (empty: the dataset it was trained on).
AvatarEvaluation evaluate_gaussian_avatar_run(const std::string& run_dir, const std::string& data_dir,
                                              const std::string& split, int64_t max_images = 0, bool progress = true);

}  // namespace fskin
