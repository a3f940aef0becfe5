#pragma once
// Rays drawn from one image of a split, with what the avatar's render of them
// is compared with, and that comparison (Fast-SNARF eq. 20-21): shared by
// training (avatar_training.h) and by fitting a held-out image's pose
// (pose_fitting.h).
#include <torch/torch.h>

#include <array>
#include <string>

#include "fskin/radiance/image_dataset.h"

namespace fskin {

struct ImageRays {
  torch::Tensor origins, directions;  // [R, 3]
  torch::Tensor target;               // [R, 3] the pixels over `background`
  torch::Tensor mask;                 // [R] in [0, 1]
  torch::Tensor background;           // [R, 3] what the render composites over
};

// `count` pixels of image `image`: round(box_fraction x count) inside `box`
// (its mask box, ends exclusive), the rest anywhere. background: "random"
// (a colour per ray, from the default generator), "white", "black" or
// "dataset" (the images' own, `dataset_background` [3]); the target is the
// image re-composited over it with the mask.
ImageRays sample_image_rays(const ImageSplit& split, int64_t image, const std::array<int64_t, 4>& box, int64_t count,
                            double box_fraction, const std::string& background, const torch::Tensor& dataset_background);

// Huber on colour (eq. 20, delta huber_delta) + opacity_weight x L1 of the
// opacity against the mask (eq. 21), means over the rays.
struct RayLoss {
  torch::Tensor colour, opacity;
  torch::Tensor total() const { return colour + opacity; }
};
RayLoss avatar_ray_loss(const torch::Tensor& color, const torch::Tensor& opacity, const torch::Tensor& target,
                        const torch::Tensor& mask, double huber_delta, double opacity_weight);

}  // namespace fskin
