#pragma once
// Training a Gaussian avatar (gaussian_avatar.h) on an image dataset
// (radiance/image_dataset.h), run by the engine's Trainer (checkpoints,
// Ctrl-C, --resume, progress, log.jsonl): per step one training image,
// rendered on the dataset's background (the subject's box of it,
// crop_margin); the loss of 3D Gaussian
// splatting, (1 - l) L1 + l (1 - SSIM) on colour (l = ssim_weight), plus
// mask_weight x L1 between the picture's alpha and the mask, plus the priors
// below (the rig silhouette prior on by default); Adam with one
// learning rate per kind of parameter (3DGS's, the means' in units of the
// character's size), decayed by the Trainer's cosine schedule; adaptive
// density control (density_control.h) after the optimiser's steps.
//
// The run directory holds gaussian_avatar.json (gaussian_config.h),
// canonical.npz (the character) and the engine's files.
#include <array>
#include <cstdint>
#include <string>
#include <utility>

#include "fskin/engine/stop_signal.h"
#include "fskin/gaussians/density_control.h"
#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/radiance/appearance_codes.h"
#include "fskin/radiance/pose_correction.h"
#include "fskin/radiance/refined_poses.h"

namespace fskin {

struct GaussianTrainOptions {
  std::string data_dir, out_dir;
  GaussianAvatarOptions avatar;
  DensityControlOptions density;
  int64_t steps = 3000;
  // Adam's learning rates (3DGS's but the rotations'): the means' times the
  // character's size. The rotations at a tenth of 3DGS's keep the discs near
  // the planes of the mesh faces they start in: turned freely they fit the
  // training views as well and, on the demo's images, draw a wider outline
  // from the others (docs/benchmarks.md, "Gaussian avatars": +0.4 dB on
  // held-out views).
  double means_learning_rate = 1.6e-4;
  double scales_learning_rate = 5e-3;
  double rotations_learning_rate = 1e-4;
  double opacity_learning_rate = 5e-2;
  double sh_learning_rate = 2.5e-3;  // degree 0; higher degrees at a 20th
  double skinning_learning_rate = 1e-3;  // the learned skinning corrections (avatar.learned_skinning)
  double non_rigid_learning_rate = 1e-3;  // the non-rigid offset's network (avatar.non_rigid)
  double shading_learning_rate = 2.5e-3;  // the shading's lighting (avatar.shading)
  // The appearance codes and their network (avatar.appearance.dim > 0), the
  // non-rigid offset's rate.
  double appearance_learning_rate = 1e-2;
  // Cosine decay of every rate to decay_factor x over the last decay_fraction of the steps.
  double decay_fraction = 1.0, decay_factor = 0.1;
  double ssim_weight = 0.2;
  double mask_weight = 0.5;
  // The learned skinning corrections' prior: this weight times their mean
  // square (per Gaussian and bone), keeping the rig's weights where the
  // images do not ask otherwise.
  double skinning_weight = 0.01;
  // The non-rigid offsets' prior: weight x mean over Gaussians of |offset / size|^2.
  double non_rigid_weight = 1.0;
  // The surface layer prior (gaussians/surface_layer.h): this weight times
  // the spread of the Gaussians' heights against the mesh, in initial
  // spacings squared; 0: none, and the avatar keeps no anchors. At 1e-2 it
  // gains the subject box 1.6 / 1.7 dB on the demo's lit images, 0.4 dB on
  // its unlit ones and 0.6 dB on the quadruped (novel views / poses, 3
  // seeds; docs/benchmarks.md); 1e-3 and 1e-1 scored 0.1-0.2 dB lower (seed
  // 0), and the inside of the outline loses 0.5 dB at 1e-3, 1 dB at 1e-2.
  double layer_weight = 1e-2;
  // The opacity prior (gaussians/opacity_prior.h, which says why it is off
  // by default): this weight times the mean binary entropy of the opacities.
  double opacity_weight = 0;
  // The unseen-view prior (gaussians/unseen_view_prior.h): this weight times
  // the opacity's binary entropy in a picture of the step's pose from its
  // camera turned by up to unseen_view_degrees (the picture the rig
  // silhouette prior reads too); 0: none.
  double alpha_entropy_weight = 0;
  double unseen_view_degrees = 45;
  // The unseen view is drawn on every this-many-th step only, its priors
  // counted this many times there (their weights stay their means per step):
  // fewer renders, a less frequent prior. At 4 the rig silhouette prior
  // scores as at 1 on the demo's images and the quadruped (3 seeds each;
  // docs/benchmarks.md, "Gaussian avatars") in 1.1-1.2 times the time of a
  // training without it, against 1.7-2.2 times.
  int64_t unseen_view_every = 4;
  // The rig silhouette prior (gaussians/rig_silhouette_prior.h): this weight
  // times the L1 distance between the unseen view's opacity (above; the
  // angle's bound is unseen_view_degrees) and the rig's posed mesh's
  // coverage; 0: none. The mask loss's weight. configure_gaussian_options
  // sets it to 0 for a dataset imported from a capture unless it is given
  // (image_dataset_mesh_is_fitted: the mesh is a fitted body model).
  double rig_silhouette_weight = 0.5;
  // The avatar's options as this training builds it (anchored with the surface layer prior).
  GaussianAvatarOptions avatar_options() const {
    auto out = avatar;
    out.anchored = layer_weight > 0;
    return out;
  }
  // Pose refinement (radiance/pose_correction.h, the volume avatar's
  // --refine-poses): a correction of every training pose learned with the
  // Gaussians, zero-mean over the poses, its squared size (radians^2, root
  // shift in units of the size) times pose_regularizer added to the loss.
  // The rotations' learning rate (the first pass's, below) is ten times the volume avatar's: a step
  // here renders one image where the volume avatar's draws rays from four, so
  // each pose's correction steps a quarter as often (40 poses: about 75 times
  // in 3,000 steps); the best of 1e-3, 3e-3, 1e-2 and 3e-2 (which diverged)
  // measured on the demo's noisy poses (docs/benchmarks.md). The root shift
  // keeps the volume avatar's 1e-3: Adam's first steps of a pose move each
  // coordinate by about the rate, and at 1e-2 that shifted the whole body by
  // 1 % of its size, as much as the noise being corrected (measured: 1e-3
  // scores 0.6-0.7 dB higher on noisy poses, 3 seeds, and 0.9-1.0 dB on
  // exact ones, seed 0).
  bool refine_poses = false;
  double pose_learning_rate = 1e-2;
  double pose_translation_learning_rate = 1e-3;
  double pose_regularizer = 1e-3;
  // Refinement in two passes. The first (pose_first_pass_steps steps, in the
  // run's pose_pass/ directory, a run directory of its own) learns the
  // corrections with Gaussians of its own, as above. The second, the run
  // itself (`steps` steps), starts the Gaussians afresh from the rig's mesh
  // and the corrections from the first pass's, stepping the rotations at
  // pose_second_pass_learning_rate. Why: Gaussians trained while the poses
  // are still wrong stay blurred after the poses are right (a plain run given
  // the first pass's poses scores 1.2 / 1.4 dB above that pass, novel views /
  // poses, 3 seeds), and sharper Gaussians then correct the poses further; at
  // 1e-3 the corrections no longer wander on poses that need none. Measured
  // against one pass (docs/benchmarks.md, "Noisy poses"; 3 seeds): noisy
  // poses 2.4 / 2.0 dB higher, exact poses 1.4 / 1.1 dB higher, for twice the
  // steps. 0: one pass, the run itself, at the first pass's rates.
  int64_t pose_first_pass_steps = 3000;
  double pose_second_pass_learning_rate = 1e-3;
  bool refines_in_two_passes() const { return refine_poses && pose_first_pass_steps > 0; }
  // Fitting (pose_fit_steps > 0, with two passes): refinement then runs
  // three passes with one round of fitting (pose_fit_rounds, below, adds a
  // pass per further round). The first as above; the second (in
  // pose_pass_2/, `steps` steps) is the two-pass flow's second; then each training pose is fitted
  // to all the images that see it, pose_fit_steps Adam steps with that pass's
  // Gaussians frozen (gaussian_pose_fitting.h, fit_gaussian_training_poses:
  // test-time fitting's rates and cosine decay), the fits made zero-mean
  // again; the run's own pass starts fresh Gaussians on the fitted poses and
  // keeps them as they are. Why: in training a pose's correction steps about
  // 75 times, from one view at a time, while the Gaussians move under it;
  // fitted to its four views at once against settled Gaussians, the demo's
  // noisy poses end half as far from the truth (the posed vertices 0.0008 of
  // the size off instead of 0.0015, seed 0), and Gaussians learnt on them
  // score 1.19 / 0.46 dB higher on novel views / poses (3 seeds,
  // docs/benchmarks.md, "Noisy poses: fitting the training poses"); a third
  // pass without the fit gains nothing. The first pass's Gaussians are too
  // blurred to fit to: rendering them costs about 6 times as much per
  // fitting step (seed 0), so the fit comes after the second pass. The fit
  // takes most of the time: 3.2 times the two passes' (demo, 2 cores).
  // 0: no fitting (two passes).
  int64_t pose_fit_steps = 100;
  // Rounds of fitting: each fits the training poses against the previous
  // pass's Gaussians, then trains fresh Gaussians on them in a pass of its
  // own, poses kept (pose_pass_3/, ...; the last round's pass is the run's
  // own). 1: the three passes above; 2: four passes, the second fit against
  // Gaussians learnt on fitted poses: on the demo's noisy poses the joints
  // end 2.0 degrees off instead of 2.3, and the novel views / poses score
  // 0.23 / 0.08 dB higher than the same runs' third passes (3 seeds; the
  // novel views 0.34 dB below exact poses' runs instead of 0.56;
  // docs/benchmarks.md, "A second round of fitting"), for about 21 more
  // minutes on 2 cores (a run about 45 minutes against 25).
  int64_t pose_fit_rounds = 2;
  bool fits_training_poses() const { return refines_in_two_passes() && pose_fit_steps > 0; }
  // Each step renders only the box of its image's mask grown by this fraction
  // of its size (mask_box), the camera cut to it; the losses stay those of the
  // whole picture (sums over the box divided by the whole picture's pixels and
  // SSIM windows: the background outside is exact and costs nothing). < 0:
  // whole pictures.
  double crop_margin = 0.2;
  int64_t checkpoint_every = 500;
  int64_t log_every = 50;
  uint64_t seed = 0;
  bool resume = false;
  bool progress = true;
  const StopSignal* stop = nullptr;  // the CLI's Ctrl-C handler
  void validate() const;
};

struct GaussianTrainSummary {
  int64_t first_step = 0, last_step = 0;
  double seconds = 0;
  double final_loss = 0, final_psnr = 0;  // of the last logged step
  int64_t gaussians = 0;                  // at the end
  bool stopped = false;
  // The first pass of pose refinement (pose_first_pass_steps) as this call
  // ran it: steps [first, last); none when it had finished before or does
  // not exist. `seconds` counts every pass.
  int64_t pose_pass_first_step = 0, pose_pass_last_step = 0;
  // The fits of the training poses this call ran: a resumed run skips a fit
  // whose following pass has begun (that pass's checkpoint holds its poses).
  int64_t pose_fits = 0;
};

GaussianTrainSummary train_gaussian_avatar(const GaussianTrainOptions& options);

// Whether a run directory holds a Gaussian avatar (its gaussian_avatar.json).
bool is_gaussian_avatar_run(const std::string& run_dir);

// The poses a Gaussian avatar run refined (radiance/refined_poses.h); throws
// fskin::Error naming the run when it does not refine poses.
RefinedPoses refined_gaussian_poses(const std::string& run_dir);

// A trained Gaussian avatar loaded from its run (newest intact checkpoint).
struct TrainedGaussianAvatar {
  GaussianAvatar avatar{nullptr};
  GaussianTrainOptions options;
  int64_t step = 0;
  // With pose refinement: the training frames' corrections, and the
  // character's skeleton and size they apply with; null without.
  PoseCorrections corrections{nullptr};
  Skeleton skeleton;
  double size = 1;
  // With appearance codes (avatar.appearance.dim > 0): the training frames'
  // codes; null without.
  AppearanceCodes appearance{nullptr};
  static TrainedGaussianAvatar load(const std::string& run_dir);
  // The bones an image of any split is rendered with (PoseCorrectionsImpl::bones_for).
  torch::Tensor bones_for(const torch::Tensor& given) const;
  // The appearance code of an image whose dataset bones are `given`: its
  // training frame's, undefined (code zero) for any other pose or without codes.
  torch::Tensor appearance_for(const torch::Tensor& given) const;
  // (rgb [H, W, 3] in [0, 1], alpha [H, W]) of bones [J, 4, 4] seen by camera,
  // with an appearance code (appearance_for; undefined: code zero), without gradients.
  std::pair<torch::Tensor, torch::Tensor> render(const torch::Tensor& bones, const PinholeCamera& camera,
                                                 const std::array<double, 3>& background,
                                                 const torch::Tensor& appearance = {});
};

}  // namespace fskin
