#pragma once
// The layout of a run directory, in one place. Every trained thing (occupancy
// models, avatars) writes the same files:
//
//   .lock                  the writer's advisory lock (engine/run_lock.h)
//   config.json            an occupancy model's TrainConfig (training/train_config.h)
//   avatar.json            an avatar's options (radiance/avatar_training.h)
//   gaussian_avatar.json   a Gaussian avatar's options (gaussians/gaussian_training.h)
//   canonical.npz          the avatar's character (its rig and canonical mesh)
//   log.jsonl              one JSON object per logged step
//   validation.jsonl       one JSON object per validation
//   best.json              the best validation scores and their step
//   checkpoint-<step>.fskin, checkpoint-best.fskin   (engine/checkpoint.h)
//   pose_pass/             a Gaussian avatar's first pass of pose refinement
//                          (gaussians/gaussian_training.h): a run directory of
//                          its own, with its log and checkpoints
//
// Files are written atomically (util/atomic_file.h); a killed write leaves a
// temporary that the next writer removes.
#include <cstdint>
#include <string>
#include <vector>

namespace fskin {

class RunDirectory {
 public:
  explicit RunDirectory(std::string path);
  const std::string& path() const { return path_; }

  std::string config_file() const;
  std::string avatar_config_file() const;
  std::string gaussian_avatar_config_file() const;
  std::string character_file() const;
  std::string log_file() const;
  std::string validation_log_file() const;
  std::string best_scores_file() const;
  std::string best_checkpoint_file() const;
  std::string lock_file() const;
  // The run directory of pass `pass` of pose refinement before the run's own
  // (gaussians/gaussian_training.h): pose_pass/, then pose_pass_2/, ...
  std::string pose_pass_directory(int pass = 1) const;
  std::vector<std::string> checkpoints() const;  // numbered ones, newest first

  // Before the first step of a writer: removes what killed writes left, then
  // either empties the logs and forgets the best checkpoint (a fresh run) or
  // keeps the log lines of the steps the resumed checkpoint holds.
  void start_logs(bool resuming, int64_t resumed_step) const;

 private:
  std::string file(const char* name) const;
  std::string path_;
};

// A log keeps only the lines of steps through `step` ("step" <= step; lines
// cut by a kill are dropped), so a run killed after its last checkpoint does
// not log those steps twice when it resumes.
void keep_log_through_step(const std::string& log_path, int64_t step);

}  // namespace fskin
