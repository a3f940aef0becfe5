#pragma once
// The one training loop of fskin. For any Trainable (engine/trainable.h) it
// owns: the stop signal (finish the step, checkpoint, return), intra-op
// threads that follow the free cores, per-step seeding, the learning-rate
// schedule, Adam, gradient clipping, the non-finite-loss stop, log.jsonl,
// the progress bar, checkpoints every N steps and at exit, validation with the
// best checkpoint kept, and --resume from the newest intact checkpoint.
// Batches and every random draw depend only on (seed, step), so a resumed run
// continues the very same schedule bit for bit (for a given thread count).
//
// The caller holds the run's lock (engine/run_lock.h) and writes its config
// before calling; the Trainer writes the rest of the run directory. With
// several ranks (engine/data_parallel.h) every rank reads the run (its
// directory must be on a file system they all see) and rank 0 alone writes.
#include <cstdint>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>
#include <torch/types.h>

#include "fskin/engine/checkpoint.h"
#include "fskin/engine/data_parallel.h"
#include "fskin/engine/run_directory.h"
#include "fskin/engine/stop_signal.h"
#include "fskin/engine/trainable.h"

namespace fskin {

// Seed of everything random in step `step` of a run seeded with `seed`.
uint64_t step_seed(uint64_t seed, int64_t step);

// The learning-rate multiplier of each step: a linear warm-up from
// warmup_factor to 1 over warmup_steps, 1, then a cosine decay down to
// decay_factor over the last decay_fraction of a run of `total_steps`.
struct LearningRateSchedule {
  int64_t warmup_steps = 0;
  double warmup_factor = 1;
  double decay_fraction = 0, decay_factor = 1;
  double scale(int64_t step, int64_t total_steps) const;
};

struct TrainerSettings {
  int64_t steps = 0;
  uint64_t seed = 0;
  LearningRateSchedule schedule;  // over `steps`
  double learning_rate = 0;  // the nominal rate, logged as "lr" x the schedule's multiplier
  double adam_eps = 1e-8;
  double grad_clip = 0;  // max gradient norm; 0: none
  int64_t log_every = 1;  // log lines hold the mean of this many steps' values
  int64_t checkpoint_every = 500;
  int keep_checkpoints = 2;
  int64_t validate_every = 0;  // 0: no validation
  bool resume = false;
  bool progress = true;
  std::string progress_label = "train";
  // Appended to the non-finite-loss error: how to lower the learning rate.
  std::string learning_rate_hint = "lower the learning rate";
  const StopSignal* stop = nullptr;
  torch::Device device = torch::kCPU;
  // Data-parallel training (engine/data_parallel.h): this process is one of
  // parallel->world_size() ranks; rank 0 alone writes the run. Null: one process.
  DataParallel* parallel = nullptr;
};

struct TrainerSummary {
  int64_t first_step = 0, last_step = 0;  // steps run: [first_step, last_step)
  double seconds = 0;
  bool stopped = false;  // by the stop signal
  bool resumed = false;  // the state came from a checkpoint
  nlohmann::json first_values, last_values;  // the logged values of the first and last step run
  nlohmann::json last_logged;               // the last log line
  int64_t best_step = -1;                   // -1: no validation ran
  nlohmann::json best_scores;
};

class Trainer {
 public:
  Trainer(RunDirectory run, TrainerSettings settings);
  TrainerSummary run(Trainable& trainable) const;

 private:
  RunDirectory run_;
  TrainerSettings settings_;
};

// Reads the model part of one checkpoint of `run` (`key` is the archive entry
// Trainable::save writes) and returns its step. `choice` as in
// engine/checkpoint.h; throws fskin::Error naming the run when there is none.
int64_t load_model_checkpoint(const RunDirectory& run, const CheckpointChoice& choice, const std::string& key,
                              const std::function<void(torch::serialize::InputArchive&)>& load_model);

}  // namespace fskin
