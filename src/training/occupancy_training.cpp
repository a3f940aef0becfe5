#include "fskin/training/occupancy_training.h"

#include <torch/torch.h>

#include <cstdio>
#include <optional>

#include "fskin/core/error.h"
#include "fskin/engine/run_directory.h"
#include "fskin/engine/run_lock.h"
#include "fskin/training/occupancy_trainable.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

LearningRateSchedule learning_rate_schedule(const TrainConfig& config) {
  LearningRateSchedule schedule;
  schedule.warmup_steps = config.warmup_steps;
  schedule.warmup_factor = config.warmup_factor;
  schedule.decay_fraction = config.decay_fraction;
  schedule.decay_factor = config.decay_factor;
  return schedule;
}

double learning_rate_scale(const TrainConfig& config, int64_t step) {
  return learning_rate_schedule(config).scale(step, config.steps);
}

TrainResult train(const TrainConfig& config, const BatchSource& source, const TrainOptions& options) {
  config.validate();
  FSKIN_CHECK(!options.run_dir.empty(), "train: no run directory given");
  FSKIN_CHECK(source.num_frames() > 0, "train: the training data has no frames");
  const RunDirectory run(options.run_dir);
  const bool writer = options.parallel == nullptr || options.parallel->rank() == 0;
  // One writer per run (rank 0 of several), locked before anything is written.
  std::optional<RunLock> lock;
  if (writer) {
    lock.emplace(run.path());
    write_file_atomically(run.config_file(), config.to_json());
  }

  torch::manual_seed(config.seed);
  // The bootstrap losses and the skinning prior use the bone segments that run
  // inside the body, or all of them (config.bootstrap_bones).
  CanonicalSkeleton skeleton = source.skeleton();
  if (config.bootstrap_bones == "all") skeleton.segment_in_body.clear();
  const auto described = model_options(config, skeleton);
  const double outside = fraction_outside_grid(described, skeleton);
  if (outside > 0)
    std::fprintf(stderr,
                 "fskin: warning: %.1f %% of the canonical body lies outside the skinning grid box and gets no "
                 "skinning weights (grid_resolution=%lld%s)\n",
                 100 * outside, static_cast<long long>(config.grid_resolution),
                 config.grid_resolution == 0 ? ": the papers' person layout; the default fits any character" : "");
  FSKIN_CHECK(config.validate_every == 0 || (options.validation != nullptr && !options.validation->empty()),
              "train: validate_every = {} but no validation frames were given", config.validate_every);
  OccupancyTrainable trainable(make_model(described), config, source, skeleton, options.validation);

  TrainerSettings settings;
  settings.steps = config.steps;
  settings.seed = config.seed;
  settings.schedule = learning_rate_schedule(config);
  settings.learning_rate = config.learning_rate;
  settings.grad_clip = config.grad_clip;
  settings.checkpoint_every = config.checkpoint_every;
  settings.keep_checkpoints = static_cast<int>(config.keep_checkpoints);
  settings.validate_every = config.validate_every;
  settings.resume = options.resume;
  settings.progress = options.progress;
  settings.learning_rate_hint = "lower learning_rate (--set learning_rate=...)";
  settings.stop = options.stop;
  settings.device = options.device;
  settings.parallel = options.parallel;
  const auto summary = Trainer(run, settings).run(trainable);

  TrainResult result;
  result.first_step = summary.first_step;
  result.last_step = summary.last_step;
  if (!summary.first_values.is_null()) result.first_loss = summary.first_values.at("bce").get<double>();
  if (!summary.last_values.is_null()) result.last_loss = summary.last_values.at("bce").get<double>();
  result.seconds = summary.seconds;
  result.skinning_prior_loss = trainable.skinning_prior_loss();
  result.stopped = summary.stopped;
  result.best_step = summary.best_step;
  if (summary.best_step >= 0) result.best_iou_surf = summary.best_scores.at("iou_surf").get<double>();
  return result;
}

std::shared_ptr<OccupancyModel> load_trained_model(const std::string& run_dir, const CanonicalSkeleton& skeleton,
                                                   int64_t* step, const CheckpointChoice& choice) {
  const RunDirectory run(run_dir);
  const auto config = TrainConfig::load_run(run.config_file());
  auto model = make_model(config, skeleton);
  const int64_t loaded = load_model_checkpoint(
      run, choice, OccupancyTrainable::kArchiveKey,
      [&model](torch::serialize::InputArchive& archive) { model->load(archive); });
  if (step) *step = loaded;
  model->train(false);
  return model;
}

}  // namespace fskin
