// fskin train: learn a canonical occupancy and skinning field from posed frames.
#include <cstdio>
#include <filesystem>

#include "cli/commands.h"
#include "fskin/core/device.h"
#include "fskin/models/model_registry.h"
#include "fskin/engine/stop_signal.h"
#include "fskin/training/train_run.h"

namespace fskin::cli {

namespace {
// The model types of the registry, one per line.
std::string method_help() {
  std::string help = "the model (model.type; default fast-snarf):";
  for (const auto& type : model_types()) help += "\n  " + type.name + ": " + type.summary;
  return help;
}
}  // namespace

void register_train(CLI::App& app) {
  struct Options {
    std::string data, method, out, config;
    int64_t steps = -1;
    std::vector<std::string> assignments;
    bool resume = false, full = false, quiet = false;
    std::string device = "cpu";
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("train", "Train an articulated occupancy model (SNARF / Fast-SNARF / baselines)");
  cmd->add_option("--data", opt->data, "dataset directory (fskin data build); default: the run's");
  cmd->add_option("--method", opt->method, method_help())->check(CLI::IsMember(method_names()));
  cmd->add_option("--out", opt->out, "run directory (config, log.jsonl, checkpoints)")->required();
  cmd->add_option("--config", opt->config, "JSON config overlaid on the defaults");
  cmd->add_option("--steps", opt->steps, "total training steps");
  cmd->add_option("--set", opt->assignments, "config override key=value (repeatable)");
  cmd->add_flag("--full", opt->full, "start from the papers' full-size config instead of the CPU demo size");
  cmd->add_flag("--resume", opt->resume, "continue from the newest intact checkpoint in --out");
  cmd->add_flag("--quiet", opt->quiet, "no progress bar");
  cmd->add_option("--device", opt->device, "cpu, cuda or cuda:N (the data stays on the host; batches move)");
  cmd->callback([opt] {
    parse_device(opt->device);  // a bad flag fails naming it, before any work
    StopSignal stop;
    TrainRunRequest request;
    request.data = opt->data;
    request.out = opt->out;
    request.method = opt->method;
    request.config_path = opt->config;
    request.steps = opt->steps;
    request.settings = opt->assignments;
    request.full = opt->full;
    request.resume = opt->resume;
    request.progress = !opt->quiet;
    request.device = opt->device;
    request.stop = &stop;
    const auto run = train_run(request, [&](const TrainConfig& config, int64_t frames) {
      std::printf("training %s on %lld frames of %s for %lld steps -> %s\n", config.method.c_str(),
                  static_cast<long long>(frames), config.data.c_str(), static_cast<long long>(config.steps),
                  opt->out.c_str());
      std::fflush(stdout);
    });
    if (run.rank != 0) return;  // rank 0 reports for every rank
    const auto& config = run.config;
    const auto& result = run.result;
    if (result.skinning_prior_loss > 0) {
      std::printf("skinning warm start: %lld steps on the skeleton's nearest-bone prior, cross-entropy %.3f\n",
                  static_cast<long long>(config.skinning_prior_steps), result.skinning_prior_loss);
    }
    std::printf("%s at step %lld: loss %.4f -> %.4f, %.1f s (%.2f steps/s)\n",
                result.stopped ? "stopped" : "finished", static_cast<long long>(result.last_step), result.first_loss,
                result.last_loss, result.seconds,
                result.seconds > 0 ? static_cast<double>(result.last_step - result.first_step) / result.seconds : 0.0);
    if (result.best_step >= 0) {
      std::printf("best on %lld val frames: step %lld, IoU_surf %.4f (checkpoint-best.fskin; --checkpoint best)\n",
                  static_cast<long long>(run.validation_frames), static_cast<long long>(result.best_step), result.best_iou_surf);
    }
  });
}

}  // namespace fskin::cli
