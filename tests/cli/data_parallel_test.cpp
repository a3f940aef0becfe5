// `fskin train` as two ranks on loopback, launched the way torchrun launches
// them (RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR, MASTER_PORT): the two
// ranks take the steps one process takes on the same global batch, rank 0
// alone writes the run, and when one rank is killed the other stops with an
// error saying so, and the run resumes.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <torch/torch.h>
#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include "cli/cli_process.h"
#include "fskin/data/inside_test.h"
#include "fskin/engine/checkpoint.h"
#include "fskin/inference/trained_run.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::spawn_cli;
using testing::wait_exit;

// A loopback port nobody listens on now (the kernel's choice for port 0).
int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
  socklen_t length = sizeof address;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  ::close(fd);
  return ntohs(address.sin_port);
}

std::vector<std::pair<std::string, std::string>> rank_environment(int rank, int world_size, int port) {
  return {{"RANK", std::to_string(rank)},       {"WORLD_SIZE", std::to_string(world_size)},
          {"LOCAL_RANK", std::to_string(rank)}, {"MASTER_ADDR", "127.0.0.1"},
          {"MASTER_PORT", std::to_string(port)}, {"FSKIN_RANK_TIMEOUT_S", "120"}};
}

class DataParallelTraining : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(testing::temp_dir("data_parallel"));
    if (!inside_test_available()) return;
    run_ok({"character", "--out", path("model.npz"), "--resolution", "40"}, "character.log");
    run_ok({"poses", "train", "--model", path("model.npz"), "--out", path("poses.npz"), "--sequences", "2", "--frames",
            "8"},
           "poses.log");
    run_ok({"data", "build", "--model", path("model.npz"), "--poses", path("poses.npz"), "--out", path("data"),
            "--points", "3000", "--quiet"},
           "data.log");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static std::string path(const std::string& name) { return (*dir_ / name).string(); }
  static void run_ok(const std::vector<std::string>& args, const std::string& log) {
    ASSERT_EQ(wait_exit(spawn_cli(args, *dir_ / log)), 0) << read_file(path(log));
  }
  static std::vector<std::string> train_args(const std::string& out, int steps, bool resume) {
    std::vector<std::string> args = {"--threads", "1",     "train", "--data", path("data"), "--out",
                                     out,         "--steps", std::to_string(steps), "--quiet"};
    for (const char* s : {"checkpoint_every=4", "frames_per_batch=2", "surface_points=300", "uniform_points=100",
                          "occupancy_hidden_dim=32", "occupancy_hidden_layers=3", "skinning_hidden_dim=16",
                          "skinning_hidden_layers=2", "grid_resolution=16", "skinning_prior_steps=0",
                          "validate_every=0"}) {
      args.push_back("--set");
      args.push_back(s);
    }
    if (resume) args.push_back("--resume");
    return args;
  }
  static int count_lines(const std::string& file) {
    std::ifstream in(file);
    int lines = 0;
    for (std::string line; std::getline(in, line);) ++lines;
    return lines;
  }
  static fs::path* dir_;
};
fs::path* DataParallelTraining::dir_ = nullptr;

TEST_F(DataParallelTraining, TwoRanksTakeTheStepsOfOneProcessOnTheSameGlobalBatch) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  run_ok(train_args(path("one"), 20, false), "one.log");
  const int port = free_port();
  const pid_t rank0 = spawn_cli(train_args(path("two"), 20, false), *dir_ / "rank0.log", rank_environment(0, 2, port));
  const pid_t rank1 = spawn_cli(train_args(path("two"), 20, false), *dir_ / "rank1.log", rank_environment(1, 2, port));
  ASSERT_EQ(wait_exit(rank0), 0) << read_file(path("rank0.log"));
  ASSERT_EQ(wait_exit(rank1), 0) << read_file(path("rank1.log"));

  auto one = TrainedRun::load(path("one")), two = TrainedRun::load(path("two"));
  const auto a = one.model->named_parameters(), b = two.model->named_parameters();
  ASSERT_EQ(a.size(), b.size());
  double largest = 0, moved = 0;
  for (const auto& item : a) {
    largest = std::max(largest, (item.value() - b[item.key()]).abs().max().item<double>());
    moved = std::max(moved, item.value().abs().max().item<double>());
  }
  std::printf("largest parameter difference after 20 steps: %.3g (largest parameter %.3g)\n", largest, moved);
  EXPECT_LT(largest, 1e-5) << "largest parameter difference after 20 steps";
  EXPECT_GT(moved, 0.0);
  // Rank 0 alone wrote the log, one line per step, and says how many ranks ran.
  EXPECT_EQ(count_lines(path("two") + "/log.jsonl"), 20);
  std::ifstream log(path("two") + "/log.jsonl");
  std::string first;
  std::getline(log, first);
  EXPECT_EQ(nlohmann::json::parse(first).at("ranks").get<int>(), 2);
}

TEST_F(DataParallelTraining, AKilledRankStopsTheOtherWithAClearErrorAndTheRunResumes) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  const std::string run = path("killed");
  int port = free_port();
  const pid_t rank0 = spawn_cli(train_args(run, 100000, false), *dir_ / "k_rank0.log", rank_environment(0, 2, port));
  const pid_t rank1 = spawn_cli(train_args(run, 100000, false), *dir_ / "k_rank1.log", rank_environment(1, 2, port));
  // Rank 1 dies once the run has a checkpoint.
  const auto deadline = Clock::now() + std::chrono::seconds(300);
  while (list_checkpoints(run).empty() && Clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_FALSE(list_checkpoints(run).empty()) << read_file(path("k_rank0.log"));
  ::kill(rank1, SIGKILL);
  EXPECT_EQ(wait_exit(rank1), 128 + SIGKILL);
  const auto killed_at = Clock::now();
  const int code = wait_exit(rank0);
  const double seconds = std::chrono::duration<double>(Clock::now() - killed_at).count();
  const auto message = read_file(path("k_rank0.log"));
  std::printf("rank 0 stopped %.2f s after rank 1 was killed:\n%s\n", seconds,
              message.substr(message.rfind("fskin: error")).c_str());
  EXPECT_NE(code, 0) << message;
  EXPECT_LT(seconds, 60) << "rank 0 noticed the lost rank after " << seconds << " s";
  EXPECT_NE(message.find("rank 0 of 2: another rank stopped answering"), std::string::npos) << message;

  // Both ranks again with --resume: the run continues from its checkpoint.
  const auto kept = list_checkpoints(run);
  ASSERT_FALSE(kept.empty());
  const std::string newest = fs::path(kept.front()).filename().string();  // checkpoint-000000NN.fskin
  const int from = std::stoi(newest.substr(11, 8));
  const int to = from + 6;
  port = free_port();
  const pid_t again0 = spawn_cli(train_args(run, to, true), *dir_ / "r_rank0.log", rank_environment(0, 2, port));
  const pid_t again1 = spawn_cli(train_args(run, to, true), *dir_ / "r_rank1.log", rank_environment(1, 2, port));
  ASSERT_EQ(wait_exit(again0), 0) << read_file(path("r_rank0.log"));
  ASSERT_EQ(wait_exit(again1), 0) << read_file(path("r_rank1.log"));
  EXPECT_EQ(fs::path(list_checkpoints(run).front()).filename().string(),
            fmt::format("checkpoint-{:08d}.fskin", to));
  EXPECT_EQ(count_lines(run + "/log.jsonl"), to);  // each step once
}

}  // namespace
}  // namespace fskin
