#pragma once
// A training run as `fskin train` and `fskin.train()` start it: the config
// from the defaults (or the full-size ones), a saved run's config when
// resuming, a JSON file and key=value settings, in that order; the dataset's
// train split; the validation frames when the config validates. One
// implementation for the CLI and the Python module.
#include <functional>
#include <string>
#include <vector>

#include "fskin/engine/stop_signal.h"
#include "fskin/training/train_config.h"
#include "fskin/training/occupancy_training.h"

namespace fskin {

struct TrainRunRequest {
  std::string data;         // dataset directory; empty: the resumed run's
  std::string out;          // run directory
  std::string method;       // empty: the config's
  std::string config_path;  // JSON overlaid on the defaults; empty: none
  int64_t steps = -1;       // < 0: the config's
  std::vector<std::string> settings;  // key=value, applied last
  bool full = false;        // start from TrainConfig::full()
  bool resume = false;      // continue from the newest intact checkpoint in out
  bool progress = true;
  std::string device = "cpu";  // cpu, cuda or cuda:N (core/device.h)
  const StopSignal* stop = nullptr;
};

struct TrainRunResult {
  TrainConfig config;
  int64_t frames = 0;             // training frames
  int64_t validation_frames = 0;  // frames the best checkpoint is chosen on
  TrainResult result;
  int rank = 0;  // this process's rank when launched as several (engine/data_parallel.h)
};

// on_start(config, frames) runs once the data is loaded, before the first step
// (on rank 0 only when launched as several ranks: engine/data_parallel.h).
TrainRunResult train_run(const TrainRunRequest& request,
                         const std::function<void(const TrainConfig&, int64_t frames)>& on_start = {});

}  // namespace fskin
