#pragma once
// Training an avatar from an image dataset (Fast-SNARF sec. 7): batches of
// rays from the training images, Huber loss on colour (eq. 20) plus L1 on
// opacity against the mask (eq. 21), Adam, run by the engine's Trainer
// (engine/trainer.h: checkpoints every `checkpoint_every` steps and on
// Ctrl-C, `resume` from the newest intact one, a progress bar, log.jsonl with
// the mean of every log_every steps). The run directory (engine/run_directory.h)
// holds avatar.json (options, dataset) and canonical.npz (the character).
#include <cstdint>
#include <string>

#include "fskin/radiance/avatar.h"
#include "fskin/radiance/appearance_codes.h"
#include "fskin/radiance/pose_correction.h"
#include "fskin/engine/data_parallel.h"
#include "fskin/engine/stop_signal.h"

namespace fskin {

struct AvatarTrainOptions {
  std::string data_dir, out_dir;
  AvatarOptions avatar;
  int64_t steps = 2000;
  int64_t rays_per_step = 4096;
  int64_t images_per_step = 4;  // rays are drawn from this many training images per step
  // Fraction of the rays drawn inside each image's mask box (grown by 20 % of its size);
  // the rest anywhere in the image.
  double mask_box_fraction = 0.9;
  double learning_rate = 1e-2;  // Adam, hash table and MLP
  // Cosine decay of the learning rate to decay_factor x over the last
  // decay_fraction of the steps (engine/trainer.h, LearningRateSchedule).
  double decay_fraction = 0.5, decay_factor = 0.05;
  double huber_delta = 0.1;     // eq. 20
  double opacity_weight = 0.1;  // eq. 21
  // Background of the rendered rays: "dataset" (the images' own), "white",
  // "black" or "random" (a colour per ray; the target is re-composited onto it
  // with the mask).
  std::string background = "random";
  // Pose refinement (radiance/pose_correction.h): per training frame, a
  // rotation per joint and a root translation learned with the avatar, at
  // pose_learning_rate (before the schedule), with pose_regularizer x the
  // frame's squared correction (radians^2 + (translation / size)^2) added to
  // the loss. Off: the bones are taken as given (InstantAvatar refines its
  // poses because fitted captures are noisy).
  bool refine_poses = false;
  double pose_learning_rate = 1e-3;
  double pose_regularizer = 1e-3;
  // With avatar.skinning "learned" (avatar.h): skinning_prior x the mean
  // squared distance of the learned weight grid from the preset one, added
  // to the loss. The grid's logits train at learning_rate.
  double skinning_prior = 1.0;
  int64_t occupancy_every = 100;   // steps between canonical occupancy updates
  int64_t occupancy_warmup = 100;  // all cells occupied until this step
  int64_t checkpoint_every = 500;
  int64_t log_every = 50;
  uint64_t seed = 0;
  bool resume = false;
  bool progress = true;
  const StopSignal* stop = nullptr;  // the CLI's Ctrl-C handler; checked before every step
  // Data-parallel ranks (engine/data_parallel.h); null: one process. Each
  // rank renders images_per_step / ranks of the step's images.
  DataParallel* parallel = nullptr;
  void validate() const;
};

struct AvatarTrainSummary {
  int64_t first_step = 0, last_step = 0;
  double seconds = 0;
  double final_loss = 0, final_psnr = 0;  // of the last logged batch
  bool stopped = false;  // by Ctrl-C / SIGTERM
};

AvatarTrainSummary train_avatar(const AvatarTrainOptions& options);

// A trained avatar loaded from its run directory (newest intact checkpoint).
struct TrainedAvatar {
  Avatar avatar{nullptr};
  AvatarTrainOptions options;
  int64_t step = 0;
  static TrainedAvatar load(const std::string& run_dir);
  // The avatar in bones [J, 4, 4] (canonical -> posed) seen by `camera`:
  // (rgb [H, W, 3] in [0, 1], opacity [H, W]), without gradients, with the
  // appearance code `appearance` (undefined: the mean appearance).
  std::pair<torch::Tensor, torch::Tensor> render(const torch::Tensor& bones, const PinholeCamera& camera,
                                                 const std::array<double, 3>& background,
                                                 const torch::Tensor& appearance = {});
  // With pose refinement: the training frames' learned corrections, and the
  // character's skeleton and size they apply with; null without.
  PoseCorrections corrections{nullptr};
  Skeleton skeleton;
  double size = 1;
  // The bones an image of any split is rendered with: a training frame's
  // corrected bones where the image's bones are that frame's given ones (the
  // novel views of training poses), else its own.
  torch::Tensor bones_for(const torch::Tensor& given) const;
  // With appearance codes: the training frames' codes; null without.
  AppearanceCodes appearance{nullptr};
  // The code an image with given bones is rendered with: its training
  // frame's, else undefined (the mean appearance).
  torch::Tensor appearance_for(const torch::Tensor& given) const;
};

}  // namespace fskin
