#include "fskin/training/train_run.h"

#include <filesystem>

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset.h"
#include "fskin/evaluation/evaluation_frame.h"
#include "fskin/training/dataset_source.h"

namespace fskin {

TrainRunResult train_run(const TrainRunRequest& request,
                         const std::function<void(const TrainConfig&, int64_t frames)>& on_start) {
  FSKIN_CHECK(!request.out.empty(), "train: no run directory (--out) given");
  const auto device = parse_device(request.device, "device");
  const auto saved = (std::filesystem::path(request.out) / "config.json").string();
  TrainConfig config = request.full ? TrainConfig::full() : TrainConfig{};
  if (!request.method.empty()) config.use_method(request.method);
  if (request.resume && std::filesystem::exists(saved)) config = TrainConfig::load_run(saved);
  if (!request.config_path.empty()) config = TrainConfig::load(request.config_path, config);
  if (!request.data.empty()) config.data = std::filesystem::absolute(request.data).string();
  if (!request.method.empty()) config.method = request.method;
  if (request.steps >= 0) config.steps = request.steps;
  for (const auto& s : request.settings) config.set(s);
  config.validate();
  FSKIN_CHECK(!config.data.empty(), "train: no --data given (and no saved run config in {})", request.out);

  const auto dataset = Dataset::load(config.data, "train");
  const DatasetBatchSource source(dataset);
  std::vector<OccupancyFrame> validation;
  if (config.validate_every > 0) {
    validation = evaluation_frames(Dataset::load(config.data, "val"));
    if (static_cast<int64_t>(validation.size()) > config.validation_frames) validation.resize(config.validation_frames);
  }
  TrainRunResult out;
  out.frames = dataset.size();
  out.validation_frames = static_cast<int64_t>(validation.size());
  if (on_start) on_start(config, out.frames);
  out.result =
      train(config, source, {request.out, request.resume, request.progress, request.stop, &validation, device});
  out.config = config;
  return out;
}

}  // namespace fskin
