#include "fskin/training/train_run.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/data/canonical_skeleton.h"
#include "fskin/data/dataset.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/thin_parts.h"
#include "fskin/evaluation/evaluation_frame.h"
#include "fskin/training/dataset_source.h"
#include "fskin/engine/data_parallel.h"
#include "fskin/engine/run_directory.h"
#include "fskin/util/atomic_file.h"

#include <fmt/format.h>

namespace fskin {
namespace {

// The coarsest spacing of a voxel box's grid, in the canonical body's units.
double coarsest_cell(const VoxelBox& box) {
  const int64_t voxels[3] = {box.shape.width, box.shape.height, box.shape.depth};
  double cell = 0;
  for (int a = 0; a < 3; ++a) cell = std::max(cell, 2.0 / (box.scale[a] * static_cast<double>(voxels[a] - 1)));
  return cell;
}

// For a grid-skinned run: raises the skinning grid to
// thin_part_grid_resolution when too much of the canonical surface is thinner
// than its cells (train_config.h), then warns (stderr) about the parts still
// thinner than them: their weights blur into their neighbours' (thin_parts.h).
void fit_grid_to_thin_parts(TrainConfig& config, const Dataset& dataset) {
  const auto& canonical = dataset.canonical();
  if (!inside_test_available() || !canonical.vertices.defined() || !canonical.faces.defined() ||
      canonical.faces.size(0) == 0)
    return;
  const auto skeleton = canonical_skeleton(dataset);
  if (auto m = model_options(config, skeleton).method; m != Method::FastSnarf && m != Method::Ins) return;
  const Mesh mesh{canonical.vertices, canonical.faces, {}};
  const auto measure = [&](const TrainConfig& c) {
    return find_thin_parts(mesh, skeleton, coarsest_cell(model_options(c, skeleton).forward_skinning.box));
  };
  auto thin = measure(config);
  if (config.grid_resolution > 0 && config.thin_part_grid_resolution > config.grid_resolution &&
      thin.thin_fraction > config.thin_part_fraction) {
    std::string schedule;
    if (model_options(config, skeleton).method == Method::FastSnarf && config.thin_part_decay_fraction >= 0 &&
        config.thin_part_decay_fraction != config.decay_fraction) {
      config.decay_fraction = config.thin_part_decay_fraction;
      schedule = fmt::format(" and the learning rate decaying over the last {:g} % of the steps "
                             "(thin_part_decay_fraction; -1 keeps decay_fraction)",
                             100 * config.decay_fraction);
    }
    std::fprintf(stderr,
                 "fskin: %.1f %% of the canonical surface is thinner than a grid_resolution=%lld cell (%.3g in the "
                 "model's units): training with grid_resolution=%lld (thin_part_grid_resolution; 0 turns this "
                 "off)%s\n",
                 100 * thin.thin_fraction, static_cast<long long>(config.grid_resolution), thin.cell,
                 static_cast<long long>(config.thin_part_grid_resolution), schedule.c_str());
    config.grid_resolution = config.thin_part_grid_resolution;
    thin = measure(config);
  }
  if (thin.bones.empty()) return;
  std::fprintf(stderr,
               "fskin: warning: %.1f %% of the canonical surface lies on parts thinner than the skinning grid's "
               "cells (%.3g in the model's units); they hang from %s. Their skinning weights blur into their neighbours' "
               "(grid_resolution=%lld; a larger one makes the cells smaller)\n",
               100 * thin.thin_fraction, thin.cell, thin.summary().c_str(),
               static_cast<long long>(config.grid_resolution));
}

}  // namespace

TrainRunResult train_run(const TrainRunRequest& request,
                         const std::function<void(const TrainConfig&, int64_t frames)>& on_start) {
  FSKIN_CHECK(!request.out.empty(), "train: no run directory (--out) given");
  const auto device = parse_device(request.device, "device");
  const auto saved = RunDirectory(request.out).config_file();
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
  check_output_apart_from_input(request.out, config.data, "train");

  const auto dataset = Dataset::load(config.data, "train");
  // On --resume too: the grid is a function of the settings and the data, so
  // settings given again (--set grid_resolution=16) end on the grid the run has.
  fit_grid_to_thin_parts(config, dataset);
  const DatasetBatchSource source(dataset);
  std::vector<OccupancyFrame> validation;
  if (config.validate_every > 0) {
    validation = evaluation_frames(Dataset::load(config.data, "val"));
    if (static_cast<int64_t>(validation.size()) > config.validation_frames) validation.resize(config.validation_frames);
  }
  TrainRunResult out;
  out.frames = dataset.size();
  out.validation_frames = static_cast<int64_t>(validation.size());
  // Launched as one of several ranks (torchrun's variables): data-parallel.
  const auto parallel = join_launch_group();
  out.rank = parallel ? parallel->rank() : 0;
  if (on_start && out.rank == 0) on_start(config, out.frames);
  out.result = train(config, source,
                     {request.out, request.resume, request.progress, request.stop, &validation, device, parallel.get()});
  out.config = config;
  return out;
}

}  // namespace fskin
