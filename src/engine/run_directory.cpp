#include "fskin/engine/run_directory.h"

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "fskin/engine/checkpoint.h"
#include "fskin/engine/run_lock.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

namespace fs = std::filesystem;

RunDirectory::RunDirectory(std::string path) : path_(std::move(path)) {}

std::string RunDirectory::file(const char* name) const { return (fs::path(path_) / name).string(); }

std::string RunDirectory::config_file() const { return file("config.json"); }
std::string RunDirectory::avatar_config_file() const { return file("avatar.json"); }
std::string RunDirectory::gaussian_avatar_config_file() const { return file("gaussian_avatar.json"); }
std::string RunDirectory::character_file() const { return file("canonical.npz"); }
std::string RunDirectory::pose_pass_directory(int pass) const {
  return pass <= 1 ? file("pose_pass") : (fs::path(path_) / ("pose_pass_" + std::to_string(pass))).string();
}
std::string RunDirectory::log_file() const { return file("log.jsonl"); }
std::string RunDirectory::validation_log_file() const { return file("validation.jsonl"); }
std::string RunDirectory::best_scores_file() const { return file("best.json"); }
std::string RunDirectory::best_checkpoint_file() const { return best_checkpoint_path(path_); }
std::string RunDirectory::lock_file() const { return RunLock::path_in(path_); }
std::vector<std::string> RunDirectory::checkpoints() const { return list_checkpoints(path_); }

void RunDirectory::start_logs(bool resuming, int64_t resumed_step) const {
  remove_stale_temporaries(path_);
  if (resuming) {
    keep_log_through_step(log_file(), resumed_step);
    keep_log_through_step(validation_log_file(), resumed_step);
    return;
  }
  write_file_atomically(log_file(), std::string());
  fs::remove(validation_log_file());
  fs::remove(best_scores_file());
  fs::remove(best_checkpoint_file());
}

void keep_log_through_step(const std::string& log_path, int64_t step) {
  if (!fs::exists(log_path)) return;
  std::istringstream in(read_file(log_path));
  std::string kept, line;
  while (std::getline(in, line)) {
    try {
      if (nlohmann::json::parse(line).at("step").get<int64_t>() <= step) kept += line + "\n";
    } catch (const nlohmann::json::exception&) {
      // A line cut by a kill: dropped.
    }
  }
  write_file_atomically(log_path, kept);
}

}  // namespace fskin
