#pragma once
// The training loop of every model: BCE on posed occupancy with the soft-max
// aggregation, plus the bootstrap losses during the first epoch and the
// configured priors (losses/); Adam. The run directory holds config.json,
// log.jsonl (one JSON object per step) and checkpoints (model, optimiser, step)
// written atomically every checkpoint_every steps and at exit. With
// validate_every > 0 the model is evaluated on validation frames every that
// many steps (validation.jsonl) and the best by IoU_surf is kept as
// checkpoint-best.fskin (best.json). Batches depend only on (seed, step), so a
// resumed run continues the very same schedule bit for bit.
#include <cstdint>
#include <memory>
#include <string>

#include "fskin/evaluation/evaluation_frame.h"
#include "fskin/models/occupancy_model.h"
#include "fskin/training/batch_source.h"
#include "fskin/training/checkpoint.h"
#include "fskin/training/stop_signal.h"
#include "fskin/training/train_config.h"

namespace fskin {

struct TrainOptions {
  std::string run_dir;
  bool resume = false;  // continue from the newest intact checkpoint in run_dir
  bool progress = true;
  const StopSignal* stop = nullptr;  // finish the step, checkpoint, return
  // Frames the best checkpoint is chosen on (needed when config.validate_every > 0).
  const std::vector<OccupancyFrame>* validation = nullptr;
  // Where the model and every batch live (core/device.h); data loading and
  // sampling stay on the host, so a run's batches are the same on any device.
  torch::Device device = torch::kCPU;
};

struct TrainResult {
  int64_t first_step = 0, last_step = 0;  // steps run: [first_step, last_step)
  double first_loss = 0, last_loss = 0;    // BCE of the first and last step run
  double seconds = 0;
  double skinning_prior_loss = 0;  // cross-entropy after the warm start (0: none ran)
  bool stopped = false;  // by the stop signal
  int64_t best_step = -1;  // step of checkpoint-best.fskin (-1: no validation ran)
  double best_iou_surf = 0;
};

// Seed of everything random in step `step` of a run seeded with `seed`.
uint64_t step_seed(uint64_t seed, int64_t step);

// The learning-rate multiplier of step `step`: linear warm-up, 1, then a
// cosine decay over the last decay_fraction of config.steps.
// The cosine decay of learning_rate_scale alone: 1 until the last
// decay_fraction of `steps`, then down to decay_factor at the last step.
double cosine_decay_scale(int64_t step, int64_t steps, double decay_fraction, double decay_factor);
double learning_rate_scale(const TrainConfig& config, int64_t step);

TrainResult train(const TrainConfig& config, const BatchSource& source, const TrainOptions& options);

// The model of a run: config.json in run_dir, weights from the checkpoint
// `choice` names (default: the newest intact one); throws fskin::Error naming
// run_dir if there is none.
std::shared_ptr<OccupancyModel> load_trained_model(const std::string& run_dir, const CanonicalSkeleton& skeleton,
                                                   int64_t* step = nullptr, const CheckpointChoice& choice = {});

}  // namespace fskin
