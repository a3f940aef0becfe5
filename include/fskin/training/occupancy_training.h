#pragma once
// Training an occupancy model (SNARF, Fast-SNARF, INS, the baselines) from a
// TrainConfig: the config written to the run, the model built, then the
// engine's Trainer (engine/trainer.h) runs the loop on an OccupancyTrainable
// (training/occupancy_trainable.h): a log line per step, checkpoints every
// checkpoint_every steps and at exit, and with validate_every > 0 the best
// checkpoint by IoU_surf on the validation frames (best.json).
#include <cstdint>
#include <memory>
#include <string>

#include "fskin/evaluation/evaluation_frame.h"
#include "fskin/models/occupancy_model.h"
#include "fskin/training/batch_source.h"
#include "fskin/engine/checkpoint.h"
#include "fskin/engine/stop_signal.h"
#include "fskin/engine/trainer.h"
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
  // Data-parallel ranks (engine/data_parallel.h); null: one process.
  DataParallel* parallel = nullptr;
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

// The config's learning-rate schedule (warm-up, then cosine decay), and its
// multiplier at one step.
LearningRateSchedule learning_rate_schedule(const TrainConfig& config);
double learning_rate_scale(const TrainConfig& config, int64_t step);

TrainResult train(const TrainConfig& config, const BatchSource& source, const TrainOptions& options);

// The model of a run: config.json in run_dir, weights from the checkpoint
// `choice` names (default: the newest intact one); throws fskin::Error naming
// run_dir if there is none.
std::shared_ptr<OccupancyModel> load_trained_model(const std::string& run_dir, const CanonicalSkeleton& skeleton,
                                                   int64_t* step = nullptr, const CheckpointChoice& choice = {});

}  // namespace fskin
