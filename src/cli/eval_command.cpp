// fskin eval: IoU_bbox / IoU_surf of a trained run on a test split.
#include <cstdio>

#include "cli/commands.h"
#include "fskin/core/device.h"
#include "fskin/inference/run_evaluation.h"

namespace fskin::cli {

void register_eval(CLI::App& app) {
  struct Options {
    std::string run, split = "test-within", data, checkpoint = "latest";
    int64_t max_frames = -1;
    bool quiet = false;
    std::string device = "cpu";
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("eval", "Evaluate a trained run: IoU_bbox, IoU_surf and timing per frame");
  cmd->add_option("run", opt->run, "run directory written by fskin train")->required();
  cmd->add_option("--split", opt->split, "test-within, test-ood, val or train")
      ->check(CLI::IsMember({"test-within", "test-ood", "val", "train"}));
  cmd->add_option("--data", opt->data, "dataset directory (default: the one the run trained on)");
  cmd->add_option("--max-frames", opt->max_frames, "evaluate only the first N frames");
  cmd->add_option("--checkpoint", opt->checkpoint,
                  "which checkpoint: latest (default), best (on the val split, needs validate_every) or a step");
  cmd->add_flag("--quiet", opt->quiet, "no progress bar");
  cmd->add_option("--device", opt->device, "cpu, cuda or cuda:N: where the model runs")->capture_default_str();
  cmd->callback([opt] {
    parse_device(opt->device);  // a bad flag fails naming it, before any work
    RunEvaluationRequest request;
    request.run = opt->run;
    request.split = opt->split;
    request.data = opt->data;
    request.checkpoint = opt->checkpoint;
    request.max_frames = opt->max_frames;
    request.progress = !opt->quiet;
    request.device = opt->device;
    const auto result = evaluate_run(request);
    std::printf("%s, step %lld, split %s (%zu frames)\n%s", result.method.c_str(), static_cast<long long>(result.step),
                opt->split.c_str(), result.metrics.frames.size(), result.metrics.table().c_str());
    std::printf("wrote %s\n", result.json_path.c_str());
  });
}

}  // namespace fskin::cli
