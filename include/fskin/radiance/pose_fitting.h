#pragma once
// Test-time pose optimisation: the pose of one image corrected
// (radiance/pose_correction.h) to fit that image with the avatar frozen, as
// avatar papers evaluate on captures whose held-out poses are fitted, and so
// noisy (InstantAvatar, NeuMan). The image being scored is the one fitted:
// scores with fitting measure the avatar given the best pose for each image
// and are not comparable with scores without it.
#include <torch/torch.h>

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "fskin/radiance/avatar.h"
#include "fskin/radiance/pose_correction.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

struct PoseFittingOptions {
  int64_t steps = 0;         // Adam steps per image; 0: no fitting
  int64_t rays = 2048;       // rays per step, 90 % inside the image's mask box
  // Adam's rates, both decayed to zero over the steps by a cosine: the
  // joints' rotations and the root shift (in units of the size). With
  // constant rates, and the root at 1e-2, Adam's last steps still move each
  // coordinate by about its rate: the Gaussian avatar's novel poses, given
  // their exact bones, scored 1.7 dB lower after fitting than before (seed 0,
  // docs/benchmarks.md, "Noisy poses"), 0.5 dB higher with the decay and 1e-3.
  double learning_rate = 1e-2;
  double translation_learning_rate = 1e-3;
  double regularizer = 1e-3;  // x the correction's squared size, as in training
  double huber_delta = 0.1, opacity_weight = 0.1;  // the training loss (avatar_training.h)
  uint64_t seed = 0;
  void validate() const;
};

// Parameters held without gradients for a scope (the avatar while a pose is
// fitted), each given back its requires_grad on leaving it.
class FrozenParameters {
 public:
  explicit FrozenParameters(std::vector<torch::Tensor> parameters);
  ~FrozenParameters();
  FrozenParameters(const FrozenParameters&) = delete;
  FrozenParameters& operator=(const FrozenParameters&) = delete;

 private:
  std::vector<torch::Tensor> parameters_;
  std::vector<bool> required_;
};

// The loss of an image rendered with bones [J, 4, 4] (differentiable in
// them) at fitting step `step`.
using PoseImageLoss = std::function<torch::Tensor(const torch::Tensor& bones, int64_t step)>;

// Any avatar's fitting: Adam on a correction (pose_correction.h) of bones
// [J, 4, 4] minimising image_loss(corrected bones, step) + options.regularizer
// x the correction's squared size, with `frozen`'s gradients off meanwhile
// (the avatar's parameters: they stay as they are). Returns the corrected
// bones (`bones` with options.steps 0).
torch::Tensor fit_pose(const torch::Tensor& bones, const Skeleton& skeleton, double size,
                       const PoseFittingOptions& options, const std::vector<torch::Tensor>& frozen,
                       const PoseImageLoss& image_loss);

// The same on frame `frame` of learned corrections, in place: its correction
// steps from where it is, regularised (as in training) by its whole size, so
// that a training pose can be fitted after a pass of training.
void fit_pose_correction(PoseCorrectionsImpl& corrections, int64_t frame, const Skeleton& skeleton, double size,
                         const PoseFittingOptions& options, const std::vector<torch::Tensor>& frozen,
                         const PoseImageLoss& image_loss);

// The corrected bones [J, 4, 4] of image `image` of `split`, starting from
// `bones`; the avatar is not changed. skeleton / size: the character's
// (corrections apply down its tree; size: geometry/character_size.h).
// appearance: the image's appearance code (the one it is rendered with;
// undefined: the mean appearance).
torch::Tensor fit_pose_to_image(Avatar& avatar, const ImageSplit& split, int64_t image, const torch::Tensor& bones,
                                const std::array<double, 3>& dataset_background, const Skeleton& skeleton, double size,
                                const PoseFittingOptions& options, const torch::Tensor& appearance = {});

}  // namespace fskin
