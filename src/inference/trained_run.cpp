#include "fskin/inference/trained_run.h"

#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/engine/run_directory.h"
#include "fskin/training/occupancy_training.h"

namespace fskin {

TrainedRun TrainedRun::load(const std::string& run_dir, const std::string& data_dir,
                            const CheckpointChoice& checkpoint, const torch::Device& device) {
  namespace fs = std::filesystem;
  FSKIN_CHECK(fs::is_directory(run_dir), "run directory {} does not exist", run_dir);
  const auto config_path = RunDirectory(run_dir).config_file();
  FSKIN_CHECK(fs::exists(config_path), "{} has no config.json: not a run directory written by `fskin train`",
              run_dir);
  TrainedRun run;
  run.dir = run_dir;
  run.config = TrainConfig::load_run(config_path);
  run.data_dir = data_dir.empty() ? run.config.data : data_dir;
  FSKIN_CHECK(!run.data_dir.empty(), "{} records no dataset; pass the dataset directory (--data)", config_path);
  // The skeleton (and with it the model's voxel box) comes from the dataset,
  // as in training.
  const auto dataset = Dataset::load_canonical(run.data_dir);
  run.skeleton = canonical_skeleton(dataset);
  run.canonical_pose = dataset.canonical().pose.to(torch::kFloat32);
  run.model = load_trained_model(run_dir, run.skeleton, &run.step, checkpoint);
  run.model->to(device);
  return run;
}

}  // namespace fskin
