#pragma once
// What the engine's Trainer (engine/trainer.h) needs from a thing it trains:
// its parameters in optimiser groups, the losses of one step, callbacks around
// the loop, validation, and its state for checkpoints. The occupancy models
// (training/occupancy_trainable.h) and the image avatar
// (radiance/avatar_training.h) implement it; the loop, seeding, schedules,
// logging, progress, checkpoints and resume are the Trainer's alone.
#include <torch/torch.h>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace fskin {

// The part of a step's batch one process computes in data-parallel training
// (engine/data_parallel.h): share `index` of `count` equal shares. The batch
// itself is the same on every rank (drawn from the step's seed); a rank's
// losses are means over its share, so the mean over the ranks is the loss
// of the whole batch.
struct Shard {
  int index = 0, count = 1;
};

struct OptimizerGroup {
  std::vector<torch::Tensor> parameters;
  double learning_rate = 0;  // before the schedule's multiplier
};

// The losses of one step. `total` is what backward() runs on (a step whose
// total needs no gradient updates nothing). The logged values are scalars,
// detached, on any device: the Trainer reads them all with one host copy.
struct StepLosses {
  torch::Tensor total;
  // Loss terms as added into `total`; the log's "loss" is their sum.
  std::vector<std::pair<std::string, torch::Tensor>> terms;
  // Measures that are not losses (a batch IoU, a PSNR): logged as they are.
  std::vector<std::pair<std::string, torch::Tensor>> metrics;
  // Host values (timings, counts), logged as they are.
  std::vector<std::pair<std::string, double>> host_metrics;
  // Logged as `throughput.first` = `throughput.second` / the step's seconds
  // (points or rays per second); no entry when the name is empty.
  std::pair<std::string, double> throughput;
};

// One validation: `scores` are logged to validation.jsonl; the best by
// `scores[Trainable::validation_score()]` (higher is better) is kept as
// checkpoint-best.fskin with best.json = scores + `details` + its step.
struct ValidationResult {
  nlohmann::json scores;
  nlohmann::json details;
};

class Trainable {
 public:
  virtual ~Trainable() = default;

  // Every trainable parameter in exactly one group (the Trainer checks).
  virtual std::vector<OptimizerGroup> optimizer_groups() = 0;
  virtual std::vector<torch::Tensor> parameters() = 0;

  // Model state in checkpoints, under the trainable's own archive key.
  virtual void save(torch::serialize::OutputArchive& archive) = 0;
  virtual void load(torch::serialize::InputArchive& archive) = 0;

  // Moves the model to the training device (after a checkpoint is read).
  virtual void to(const torch::Device& device) = 0;
  // Once, before the first step; `resumed` says the state came from a checkpoint.
  virtual void on_start(bool resumed) { (void)resumed; }
  // The losses of step `step` (0-based) on `shard` of its batch. Everything
  // random in it draws from `seed` or from the default generator, which the
  // Trainer seeds per step. A model that cannot split its batch `count` ways
  // throws fskin::Error saying why.
  virtual StepLosses step_losses(int64_t step, uint64_t seed, const Shard& shard) = 0;
  // After step `step`'s optimiser update (0-based; not called for a step
  // without gradients). A model that changes its parameters' sizes during
  // training (a Gaussian avatar's densification) does it here and resizes
  // the optimiser's per-parameter state alongside.
  virtual void after_step(int64_t step, torch::optim::Adam& optimizer) {
    (void)step;
    (void)optimizer;
  }
  // The progress bar's text for one step's logged values (the Trainer adds it/s).
  virtual std::string progress_text(const nlohmann::json& step_values) const = 0;

  // Validation, when the trainer's settings ask for it every N steps.
  virtual std::optional<ValidationResult> validate() { return std::nullopt; }
  virtual std::string validation_score() const { return "score"; }
};

}  // namespace fskin
