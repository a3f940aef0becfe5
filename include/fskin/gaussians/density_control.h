#pragma once
// Adaptive density control of a Gaussian avatar (3DGS, Kerbl et al. 2023,
// sec. 5.2): Gaussians whose projected means keep large gradients are
// under-reconstructed: small ones are cloned, large ones split in two; nearly
// transparent or oversized ones are pruned; opacities are reset now and then
// so that floaters must earn their opacity again. Adam's moments follow the
// Gaussians they belong to (new ones start from zero).
#include <torch/torch.h>

#include <cstdint>

#include "fskin/gaussians/gaussian_avatar.h"

namespace fskin {

struct DensityControlOptions {
  int64_t start = 300;           // first step that densifies
  double stop_fraction = 0.5;    // no densification in the last (1 - this) of the steps
  int64_t every = 100;           // steps between densifications
  // Mean norm of a Gaussian's projected-mean gradient, in the normalised
  // device coordinates of 3DGS (pixels x 2 / image size), above which it grows.
  double gradient_threshold = 2e-4;
  double dense_fraction = 0.01;      // of the character's size: clone below, split above
  double min_opacity = 0.005;        // pruned below
  double max_scale_fraction = 0.1;   // pruned when its widest axis is larger (of the size)
  // Also pruned when its widest axis exceeds this many initial spacings
  // (GaussianAvatarImpl::initial_spacing; 0: no such bound): wide Gaussians
  // fit the training cameras' outlines and overhang elsewhere.
  double max_scale_spacings = 3.0;
  int64_t opacity_reset_every = 1500;  // 0: never
  int64_t max_gaussians = 300000;    // no growth beyond
  void validate() const;
};

// Per Gaussian, the running sum of its projected means' gradient norms and the
// number of views it was drawn in (3DGS's xyz_gradient_accum / denom).
class DensityStatistics {
 public:
  void reset(int64_t gaussians);
  // means2d_grad [N, 2] in pixels, radii [N] (drawn where > 0) of one
  // rendered picture width x height.
  void add(const torch::Tensor& means2d_grad, const torch::Tensor& radii, int64_t width, int64_t height);
  // Mean gradient norm per Gaussian (0 where never drawn).
  torch::Tensor mean_gradient() const;
  int64_t size() const { return sum_.defined() ? sum_.size(0) : 0; }
  // The running sums, for checkpoints, and their restoration.
  const torch::Tensor& sum() const { return sum_; }
  const torch::Tensor& count() const { return count_; }
  void restore(torch::Tensor sum, torch::Tensor count);

 private:
  torch::Tensor sum_, count_;
};

struct DensityChange {
  int64_t cloned = 0, split = 0, pruned = 0;
};

// One densification and pruning of `avatar` (size: the character's size, the
// unit of the scale thresholds); `adam` holds the avatar's parameters, its
// moments are gathered alongside. Draws the split Gaussians' positions from
// the default generator.
DensityChange densify_and_prune(GaussianAvatarImpl& avatar, const DensityStatistics& statistics,
                                torch::optim::Adam& adam, const DensityControlOptions& options, double size);

// Opacities above `ceiling` set to it (3DGS resets to 0.01), their moments zeroed.
void reset_opacities(GaussianAvatarImpl& avatar, torch::optim::Adam& adam, double ceiling);

}  // namespace fskin
