// fskin eval: IoU_bbox / IoU_surf of a trained run on a test split.
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "cli/commands.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset.h"
#include "fskin/evaluation/evaluation.h"
#include "fskin/inference/trained_run.h"
#include "fskin/util/atomic_file.h"

namespace fskin::cli {

void register_eval(CLI::App& app) {
  struct Options {
    std::string run, split = "test-within", data, checkpoint = "latest";
    int64_t max_frames = -1;
    bool quiet = false;
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
  cmd->callback([opt] {
    std::string split = opt->split;
    std::replace(split.begin(), split.end(), '-', '_');
    const auto checkpoint = CheckpointChoice::parse(opt->checkpoint);
    auto run = TrainedRun::load(opt->run, opt->data, checkpoint);
    const auto& config = run.config;
    const auto step = run.step;
    auto& model = run.model;
    const auto test_set = Dataset::load(run.data_dir, split);
    auto frames = evaluation_frames(test_set);
    if (opt->max_frames >= 0 && opt->max_frames < static_cast<int64_t>(frames.size())) frames.resize(opt->max_frames);
    const auto result = evaluate(*model, frames, opt->split, config.eval_chunk_points, !opt->quiet);
    const auto out = (std::filesystem::path(opt->run) / ("eval-" + opt->split + ".json")).string();
    auto json = nlohmann::json::parse(result.to_json());
    json["method"] = config.method;
    json["step"] = step;
    json["checkpoint"] = checkpoint.describe();
    write_file_atomically(out, json.dump(2) + "\n");
    std::printf("%s, step %lld, split %s (%zu frames)\n%s", config.method.c_str(), static_cast<long long>(step),
                opt->split.c_str(), frames.size(), result.table().c_str());
    std::printf("wrote %s\n", out.c_str());
  });
}

}  // namespace fskin::cli
