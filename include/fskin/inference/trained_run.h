#pragma once
// A trained run as the commands that use one (eval, mesh, animate) need it:
// its config, the dataset it trained on, the canonical skeleton of that
// dataset and the model from the chosen checkpoint (default: the newest
// intact one), in inference mode, on `device` (core/device.h).
#include <memory>
#include <string>

#include "fskin/data/dataset.h"
#include "fskin/data/canonical_skeleton.h"
#include "fskin/models/occupancy_model.h"
#include "fskin/engine/checkpoint.h"
#include "fskin/training/train_config.h"

namespace fskin {

struct TrainedRun {
  std::string dir;
  TrainConfig config;
  std::string data_dir;  // config.data, or the override
  CanonicalSkeleton skeleton;
  torch::Tensor canonical_pose;  // [J, 3] the dataset's canonical pose (canonical.npz)
  std::shared_ptr<OccupancyModel> model;
  int64_t step = 0;

  // Throws fskin::Error naming `run_dir` when it is not a run directory, has no
  // such checkpoint or records no dataset (and `data_dir` is empty).
  static TrainedRun load(const std::string& run_dir, const std::string& data_dir = "",
                         const CheckpointChoice& checkpoint = {}, const torch::Device& device = torch::kCPU);
};

}  // namespace fskin
