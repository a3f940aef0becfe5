// kill -9 at seeded random moments of `fskin data build` and `fskin train`
// (checkpoint writes included), then the same command again / --resume:
// every file left is whole (checkpoints pass their CRC, frames load, no
// temporaries survive the restart), and the finished result equals an
// uninterrupted run's, byte for byte for the dataset and parameter for
// parameter for the training. A full disk (a file-size limit: writes fail
// with EFBIG, as they fail with ENOSPC) is an error naming the file and
// leaves the previous checkpoint intact.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <torch/torch.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "fskin/data/dataset.h"
#include "fskin/data/dataset_frame.h"
#include "fskin/data/inside_test.h"
#include "fskin/engine/checkpoint.h"
#include "fskin/inference/trained_run.h"
#include "fskin/training/occupancy_training.h"
#include "fskin/util/atomic_file.h"
#include "cli/cli_process.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

using testing::wait_exit;

pid_t spawn(const std::vector<std::string>& args, const fs::path& log) { return testing::spawn_cli(args, log); }

double run_to_end(const std::vector<std::string>& args, const fs::path& log) {
  const auto start = Clock::now();
  const int code = wait_exit(spawn(args, log));
  EXPECT_EQ(code, 0) << read_file(log.string());
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Starts the command, kills it with SIGKILL after `seconds` (if still running).
void run_and_kill(const std::vector<std::string>& args, const fs::path& log, double seconds) {
  const pid_t pid = spawn(args, log);
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  int status = 0;
  while (Clock::now() < deadline) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return;  // finished first
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
}

std::vector<fs::path> temporaries(const fs::path& dir) {
  std::vector<fs::path> found;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) found.push_back(e.path());
  return found;
}

class CrashSafety : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(testing::temp_dir("crash_safety"));
    const auto path = [](const std::string& name) { return (*dir_ / name).string(); };
    run_to_end({"character", "--out", path("model.npz"), "--resolution", "40"}, *dir_ / "character.log");
    run_to_end({"poses", "train", "--model", path("model.npz"), "--out", path("poses.npz"), "--sequences", "2",
                "--frames", "12"},
               *dir_ / "poses.log");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static std::string path(const std::string& name) { return (*dir_ / name).string(); }
  static std::vector<std::string> build_args(const std::string& out) {
    return {"data", "build", "--model", path("model.npz"), "--poses", path("poses.npz"), "--out", out, "--points",
            "4000", "--quiet"};
  }
  static fs::path* dir_;
};
fs::path* CrashSafety::dir_ = nullptr;

TEST_F(CrashSafety, DataBuildKilledAnywhereThenRerunGivesTheSameBytes) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  const double whole = run_to_end(build_args(path("whole")), *dir_ / "whole.log");
  std::mt19937_64 rng(7);
  for (int round = 0; round < 3; ++round) {
    const double at = std::uniform_real_distribution<double>(0.1, 0.9)(rng) * whole;
    run_and_kill(build_args(path("killed")), *dir_ / "killed.log", at);
    if (!fs::exists(path("killed"))) continue;
    // Whatever is there under a final name is whole.
    for (const auto& e : fs::directory_iterator(path("killed")))
      if (e.path().extension() == ".npz") EXPECT_NO_THROW(DatasetFrame::load(e.path().string())) << e.path();
  }
  run_to_end(build_args(path("killed")), *dir_ / "rerun.log");
  EXPECT_TRUE(temporaries(path("killed")).empty());
  size_t compared = 0;
  for (const auto& e : fs::directory_iterator(path("whole"))) {
    const auto other = fs::path(path("killed")) / e.path().filename();
    ASSERT_TRUE(fs::exists(other)) << other;
    if (e.path().extension() == ".npz") {
      EXPECT_EQ(read_file(e.path().string()), read_file(other.string())) << e.path().filename();
      ++compared;
    }
  }
  EXPECT_GT(compared, 20u);
}

std::vector<std::string> train_args(const std::string& data, const std::string& out, int steps, bool resume) {
  std::vector<std::string> args = {"--threads", "1",   "train", "--data", data, "--out",
                                   out,         "--steps", std::to_string(steps), "--quiet"};
  for (const char* s : {"checkpoint_every=3", "frames_per_batch=2", "surface_points=400", "uniform_points=200",
                        "occupancy_hidden_dim=32", "occupancy_hidden_layers=3", "skinning_hidden_dim=16",
                        "skinning_hidden_layers=2", "grid_resolution=16", "skinning_prior_steps=0", "validate_every=0",
                        "keep_checkpoints=100"}) {
    args.push_back("--set");
    args.push_back(s);
  }
  if (resume) args.push_back("--resume");
  return args;
}

TEST_F(CrashSafety, TrainingKilledAnywhereThenResumedEqualsUninterrupted) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  const auto data = path("train_data");
  run_to_end(build_args(data), *dir_ / "train_data.log");
  const int steps = 30;
  const double whole = run_to_end(train_args(data, path("run_whole"), steps, false), *dir_ / "run_whole.log");
  std::mt19937_64 rng(11);
  bool started = false;
  for (int round = 0; round < 3; ++round) {
    const double at = std::uniform_real_distribution<double>(0.3, 0.95)(rng) * whole;
    run_and_kill(train_args(data, path("run_killed"), steps, started), *dir_ / "run_killed.log", at);
    started = fs::exists(fs::path(path("run_killed")) / "config.json");
    // Every checkpoint under its final name passes its CRC.
    for (const auto& c : list_checkpoints(path("run_killed"))) EXPECT_NO_THROW(read_checkpoint_payload(c)) << c;
  }
  run_to_end(train_args(data, path("run_killed"), steps, started), *dir_ / "run_resumed.log");
  EXPECT_TRUE(temporaries(path("run_killed")).empty());
  const auto a = list_checkpoints(path("run_whole")), b = list_checkpoints(path("run_killed"));
  ASSERT_FALSE(a.empty());
  ASSERT_FALSE(b.empty());
  EXPECT_EQ(fs::path(a.front()).filename(), fs::path(b.front()).filename());
  EXPECT_EQ(fs::path(b.front()).filename(), "checkpoint-00000030.fskin");
  auto whole_run = TrainedRun::load(path("run_whole")), killed_run = TrainedRun::load(path("run_killed"));
  const auto pa = whole_run.model->named_parameters(), pb = killed_run.model->named_parameters();
  ASSERT_EQ(pa.size(), pb.size());
  for (const auto& item : pa) EXPECT_TRUE(torch::equal(item.value(), pb[item.key()])) << item.key();
  // The log holds every step once.
  std::ifstream log(fs::path(path("run_killed")) / "log.jsonl");
  int lines = 0;
  for (std::string line; std::getline(log, line);) ++lines;
  EXPECT_EQ(lines, steps);
}

TEST_F(CrashSafety, AFullDiskIsAnErrorNamingTheFileAndKeepsThePreviousCheckpoint) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  const auto data = path("disk_data");
  run_to_end(build_args(data), *dir_ / "disk_data.log");
  const auto run = path("run_disk");
  run_to_end(train_args(data, run, 6, false), *dir_ / "disk_first.log");
  const auto before = list_checkpoints(run);
  ASSERT_FALSE(before.empty());
  const auto newest = before.front();
  const auto size_kb = static_cast<long long>(fs::file_size(newest) / 1024);
  // The next checkpoint cannot be written whole: bash's ulimit -f counts 1024-byte blocks.
  std::string command = "trap '' XFSZ; ulimit -f " + std::to_string(std::max(1LL, size_kb / 2)) + "; exec '" +
                        FSKIN_CLI_PATH + "'";
  for (const auto& a : train_args(data, run, 12, true)) command += " '" + a + "'";
  command += " > '" + path("disk_full.log") + "' 2>&1";
  const int status = std::system(("/bin/bash -c \"" + command + "\"").c_str());
  const std::string log = read_file((*dir_ / "disk_full.log").string());
  EXPECT_NE(status, 0) << log;
  EXPECT_NE(log.find("File too large"), std::string::npos) << log;
  EXPECT_NE(log.find(".fskin"), std::string::npos) << log;  // names the checkpoint it could not write
  EXPECT_EQ(log.find("internal error"), std::string::npos) << log;
  EXPECT_NO_THROW(read_checkpoint_payload(newest));
  EXPECT_EQ(list_checkpoints(run).front(), newest);
  EXPECT_TRUE(temporaries(run).empty());
  // With room again, the run resumes from it.
  run_to_end(train_args(data, run, 12, true), *dir_ / "disk_resumed.log");
  EXPECT_NE(fs::path(list_checkpoints(run).front()).filename(), fs::path(newest).filename());
}

}  // namespace
}  // namespace fskin
