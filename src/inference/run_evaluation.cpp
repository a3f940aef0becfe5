#include "fskin/inference/run_evaluation.h"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset.h"
#include "fskin/inference/trained_run.h"
#include "fskin/engine/checkpoint.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

RunEvaluation evaluate_run(const RunEvaluationRequest& request) {
  FSKIN_CHECK(request.split == "test-within" || request.split == "test-ood" || request.split == "val" ||
                  request.split == "train",
              "evaluate: split '{}' is not test-within, test-ood, val or train", request.split);
  std::string split = request.split;
  std::replace(split.begin(), split.end(), '-', '_');
  const auto checkpoint = CheckpointChoice::parse(request.checkpoint);
  const auto device = parse_device(request.device, "device");
  auto run = TrainedRun::load(request.run, request.data, checkpoint, device);
  const auto test_set = Dataset::load(run.data_dir, split);
  auto frames = evaluation_frames(test_set);
  if (request.max_frames >= 0 && request.max_frames < static_cast<int64_t>(frames.size()))
    frames.resize(request.max_frames);
  RunEvaluation out;
  out.metrics = evaluate(*run.model, frames, request.split, run.config.eval_chunk_points, request.progress);
  out.method = run.config.method;
  out.step = run.step;
  out.checkpoint = checkpoint.describe();
  auto json = nlohmann::json::parse(out.metrics.to_json());
  json["method"] = out.method;
  json["step"] = out.step;
  json["checkpoint"] = out.checkpoint;
  out.json = json.dump(2) + "\n";
  out.json_path = (std::filesystem::path(request.run) / ("eval-" + request.split + ".json")).string();
  if (request.write_json) write_file_atomically(out.json_path, out.json);
  return out;
}

}  // namespace fskin
