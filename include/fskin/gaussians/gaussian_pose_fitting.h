#pragma once
// Test-time pose optimisation for a Gaussian avatar (the volume avatar's is
// radiance/pose_fitting.h, whose options and core it shares): the pose of one
// image corrected to fit that image with the Gaussians frozen. The loss is the
// training loss without its SSIM term: mean L1 on colour plus mask_weight x
// mean L1 between the picture's alpha and the mask, over the image's mask box
// grown by 20 %.
#include <torch/types.h>

#include <array>
#include <cstdint>
#include <vector>

#include "fskin/engine/stop_signal.h"
#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/radiance/appearance_codes.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/pose_correction.h"
#include "fskin/radiance/pose_fitting.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

// The corrected bones [J, 4, 4] of image `image` of `split`, starting from
// `bones`; the avatar is not changed. skeleton / size: the character's.
// appearance: the code the image is rendered with (undefined: code zero, the
// frames' average appearance).
torch::Tensor fit_gaussian_pose_to_image(GaussianAvatarImpl& avatar, const ImageSplit& split, int64_t image,
                                         const torch::Tensor& bones, const std::array<double, 3>& background,
                                         const Skeleton& skeleton, double size, double mask_weight,
                                         const PoseFittingOptions& options, const torch::Tensor& appearance = {});

// Every training frame's learned correction fitted in place, frame by frame,
// to the images that see it (frame_of: per image of `split`, its frame,
// frames_of_images), with the Gaussians frozen, each frame rendered with its
// appearance code (appearance: the run's codes, one per frame; null: an avatar
// without codes); on the CPU the frames are fitted side by side, one per
// thread, each as it would be alone; a progress bar over the frames when
// `progress`. Returns false when `stop` was requested before the last frame
// (the frames fitted so far keep their fit).
bool fit_gaussian_training_poses(GaussianAvatarImpl& avatar, const ImageSplit& split,
                                 const std::vector<int64_t>& frame_of, PoseCorrectionsImpl& corrections,
                                 const AppearanceCodesImpl* appearance, const std::array<double, 3>& background,
                                 const Skeleton& skeleton, double size, double mask_weight,
                                 const PoseFittingOptions& options, bool progress, const StopSignal* stop = nullptr);

}  // namespace fskin
