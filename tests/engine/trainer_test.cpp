#include "fskin/engine/trainer.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "fskin/engine/checkpoint.h"
#include "fskin/engine/run_directory.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// The smallest trainable: fit w . x to 3 x0 - 2 x1 on random batches drawn from
// the step's default generator; validation scores -|w - w*|.
class LinearFit : public Trainable {
 public:
  explicit LinearFit(int64_t nan_at_step = -1) : nan_at_step_(nan_at_step) {
    torch::manual_seed(0);
    w_ = torch::randn({2}, torch::kFloat64).requires_grad_(true);
  }
  std::vector<OptimizerGroup> optimizer_groups() override { return {{{w_}, 0.05}}; }
  std::vector<torch::Tensor> parameters() override { return {w_}; }
  void save(torch::serialize::OutputArchive& archive) override {
    torch::serialize::OutputArchive model;
    model.write("w", w_);
    archive.write("linear", model);
  }
  void load(torch::serialize::InputArchive& archive) override {
    torch::serialize::InputArchive model;
    archive.read("linear", model);
    torch::Tensor w;
    model.read("w", w);
    torch::NoGradGuard no_grad;
    w_.copy_(w);
  }
  void to(const torch::Device&) override {}
  void on_start(bool resumed) override { started_resumed = resumed; }
  StepLosses step_losses(int64_t step, uint64_t, const Shard& shard) override {
    const auto all = torch::randn({16, 2}, torch::kFloat64);
    const auto x = all.narrow(0, shard.index * 16 / shard.count, 16 / shard.count);
    const auto target = x.matmul(torch::tensor({3.0, -2.0}, torch::kFloat64));
    auto loss = (x.matmul(w_) - target).pow(2).mean();
    if (step + 1 == nan_at_step_) loss = loss * std::numeric_limits<double>::quiet_NaN();
    StepLosses out;
    out.total = loss;
    out.terms = {{"mse", loss.detach()}};
    out.metrics = {{"w0", w_.detach()[0]}};
    out.host_metrics = {{"step_twice", 2.0 * static_cast<double>(step)}};
    out.throughput = {"rows_per_s", 16.0 / shard.count};
    return out;
  }
  std::string progress_text(const nlohmann::json& values) const override {
    return "mse " + std::to_string(values.at("mse").get<double>());
  }
  std::optional<ValidationResult> validate() override {
    const double error = (w_.detach() - torch::tensor({3.0, -2.0}, torch::kFloat64)).abs().sum().item<double>();
    return ValidationResult{{{"score", -error}}, {{"note", "linear"}}};
  }
  torch::Tensor weights() const { return w_.detach().clone(); }
  bool started_resumed = false;

 private:
  torch::Tensor w_;
  int64_t nan_at_step_;
};

TrainerSettings settings(int64_t steps) {
  TrainerSettings s;
  s.steps = steps;
  s.seed = 3;
  s.learning_rate = 0.05;
  s.checkpoint_every = 10;
  s.progress = false;
  return s;
}

std::vector<nlohmann::json> read_lines(const std::string& path) {
  std::vector<nlohmann::json> lines;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

TEST(EngineTrainer, FitsLogsEveryStepAndCheckpoints) {
  const RunDirectory run(testing::temp_dir("engine_fit").string());
  LinearFit fit;
  const auto summary = Trainer(run, settings(60)).run(fit);
  EXPECT_EQ(summary.first_step, 0);
  EXPECT_EQ(summary.last_step, 60);
  EXPECT_FALSE(summary.resumed);
  EXPECT_NEAR(fit.weights()[0].item<double>(), 3.0, 0.1);
  EXPECT_NEAR(fit.weights()[1].item<double>(), -2.0, 0.1);
  const auto lines = read_lines(run.log_file());
  ASSERT_EQ(lines.size(), 60u);
  EXPECT_EQ(lines[5].at("step").get<int64_t>(), 6);
  EXPECT_DOUBLE_EQ(lines[5].at("loss").get<double>(), lines[5].at("mse").get<double>());  // the sum of the terms
  EXPECT_DOUBLE_EQ(lines[5].at("step_twice").get<double>(), 10.0);  // host metrics as given (of step 5)
  for (const char* key : {"w0", "lr", "seconds", "threads", "rows_per_s"}) EXPECT_TRUE(lines[5].contains(key)) << key;
  EXPECT_LT(lines.back().at("mse").get<double>(), 0.05 * lines.front().at("mse").get<double>());
  // The gradients' norm, before any clipping, shrinks as the fit converges.
  double early = 0, late = 0;
  for (size_t i = 0; i < 5; ++i) {
    early += lines[i].at("grad_norm").get<double>();
    late += lines[lines.size() - 1 - i].at("grad_norm").get<double>();
  }
  EXPECT_GT(early, 2 * late);
  EXPECT_EQ(run.checkpoints().size(), 2u);  // kept: the newest two
  EXPECT_NE(run.checkpoints().front().find("00000060"), std::string::npos);
}

TEST(EngineTrainer, ClippingLogsTheNormBeforeItClips) {
  const RunDirectory free(testing::temp_dir("engine_unclipped").string()),
      clipped(testing::temp_dir("engine_clipped").string());
  LinearFit a, b;
  auto s = settings(5);
  Trainer(free, s).run(a);
  s.grad_clip = 1e-3;
  Trainer(clipped, s).run(b);
  const auto unclipped_lines = read_lines(free.log_file()), clipped_lines = read_lines(clipped.log_file());
  const double first = unclipped_lines[0].at("grad_norm").get<double>();
  EXPECT_GT(first, 1e-2);
  EXPECT_NEAR(clipped_lines[0].at("grad_norm").get<double>(), first, 1e-9 * first);  // the same first step
  // Adam's first step ignores the gradient's scale; the later ones weigh the
  // clipped gradients against their moments, so the runs part.
  EXPECT_FALSE(torch::equal(a.weights(), b.weights()));
}

TEST(EngineTrainer, LogLinesHoldTheMeanOfLogEverySteps) {
  const RunDirectory every(testing::temp_dir("engine_log_1").string()), fifth(testing::temp_dir("engine_log_5").string());
  LinearFit a, b;
  auto s = settings(23);
  Trainer(every, s).run(a);
  s.log_every = 5;
  Trainer(fifth, s).run(b);
  const auto all = read_lines(every.log_file()), grouped = read_lines(fifth.log_file());
  ASSERT_EQ(grouped.size(), 5u);  // steps 5, 10, 15, 20 and the last, 23
  EXPECT_EQ(grouped[4].at("step").get<int64_t>(), 23);
  double sum = 0;
  for (int i = 5; i < 10; ++i) sum += all[i].at("mse").get<double>();
  EXPECT_NEAR(grouped[1].at("mse").get<double>(), sum / 5, 1e-12);
  EXPECT_DOUBLE_EQ(grouped[1].at("lr").get<double>(), all[9].at("lr").get<double>());  // the last step's
}

TEST(EngineTrainer, ResumeContinuesBitForBit) {
  const RunDirectory whole(testing::temp_dir("engine_whole").string()), parts(testing::temp_dir("engine_parts").string());
  LinearFit uninterrupted;
  Trainer(whole, settings(40)).run(uninterrupted);

  LinearFit first;
  Trainer(parts, settings(25)).run(first);  // checkpoints at 10, 20 and 25
  // A kill after step 25's checkpoint leaves log lines past it and a temporary.
  {
    std::ofstream log(parts.log_file(), std::ios::app);
    log << nlohmann::json{{"step", 26}, {"mse", 1.0}}.dump() << "\n{\"step\": 2";
  }
  std::ofstream(parts.path() + "/checkpoint-00000030.fskin.tmp-999999999") << "partial";
  LinearFit second;  // other initial weights would show if the checkpoint were not read
  auto s = settings(40);
  s.resume = true;
  const auto summary = Trainer(parts, s).run(second);
  EXPECT_TRUE(summary.resumed);
  EXPECT_TRUE(second.started_resumed);
  EXPECT_EQ(summary.first_step, 25);
  EXPECT_TRUE(torch::equal(second.weights(), uninterrupted.weights()));
  const auto lines = read_lines(parts.log_file());
  ASSERT_EQ(lines.size(), 40u);  // each step once
  for (size_t i = 0; i < lines.size(); ++i) EXPECT_EQ(lines[i].at("step").get<int64_t>(), static_cast<int64_t>(i + 1));
  EXPECT_EQ(read_lines(whole.log_file())[30].at("mse"), lines[30].at("mse"));
  EXPECT_FALSE(fs::exists(parts.path() + "/checkpoint-00000030.fskin.tmp-999999999"));
}

TEST(EngineTrainer, ResumeWithoutACheckpointStartsAtStepZero) {
  const RunDirectory run(testing::temp_dir("engine_resume_empty").string());
  LinearFit fit;
  auto s = settings(5);
  s.resume = true;
  const auto summary = Trainer(run, s).run(fit);
  EXPECT_FALSE(summary.resumed);
  EXPECT_EQ(summary.first_step, 0);
  EXPECT_EQ(summary.last_step, 5);
}

TEST(EngineTrainer, StopSignalFinishesTheStepAndCheckpoints) {
  const RunDirectory run(testing::temp_dir("engine_stop").string());
  LinearFit fit;
  StopSignal stop;
  auto s = settings(1000);
  s.stop = &stop;
  StopSignal::request();
  const auto summary = Trainer(run, s).run(fit);
  EXPECT_TRUE(summary.stopped);
  EXPECT_EQ(summary.last_step, 0);
  EXPECT_EQ(run.checkpoints().size(), 1u);  // step 0: the run loads
}

TEST(EngineTrainer, NonFiniteLossStopsNamingTheRunStepAndKeptCheckpoint) {
  const RunDirectory run(testing::temp_dir("engine_nan").string());
  LinearFit fit(/*nan_at_step=*/14);
  auto s = settings(30);
  s.learning_rate_hint = "try --lr 0.01";
  testing::expect_error([&] { Trainer(run, s).run(fit); },
                        {run.path(), "the loss became nan at step 14", "(step 10) is kept", "try --lr 0.01 and resume"});
}

TEST(EngineTrainer, KeepsTheBestValidationCheckpoint) {
  const RunDirectory run(testing::temp_dir("engine_best").string());
  LinearFit fit;
  auto s = settings(30);
  s.validate_every = 10;
  const auto summary = Trainer(run, s).run(fit);
  const auto rows = read_lines(run.validation_log_file());
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(summary.best_step, 30);  // the fit only improves
  const auto best = nlohmann::json::parse(read_file(run.best_scores_file()));
  EXPECT_EQ(best.at("step").get<int64_t>(), 30);
  EXPECT_EQ(best.at("note").get<std::string>(), "linear");
  EXPECT_DOUBLE_EQ(best.at("score").get<double>(), rows[2].at("score").get<double>());
  EXPECT_TRUE(fs::exists(run.best_checkpoint_file()));
}

TEST(EngineTrainer, RefusesAModelWithParametersOutsideItsGroups) {
  class Forgetful : public LinearFit {
   public:
    std::vector<torch::Tensor> parameters() override { return {weights().requires_grad_(true), extra_}; }
    torch::Tensor extra_ = torch::zeros({1}, torch::kFloat64).requires_grad_(true);
  };
  Forgetful model;
  testing::expect_error([&] { Trainer(RunDirectory(testing::temp_dir("engine_groups").string()), settings(3)).run(model); },
                        {"parameter groups hold 1 of its 2 parameters"});
}

TEST(RunDirectory, NamesEveryFileOfARun) {
  const RunDirectory run("/runs/a");
  EXPECT_EQ(run.config_file(), "/runs/a/config.json");
  EXPECT_EQ(run.avatar_config_file(), "/runs/a/avatar.json");
  EXPECT_EQ(run.character_file(), "/runs/a/canonical.npz");
  EXPECT_EQ(run.log_file(), "/runs/a/log.jsonl");
  EXPECT_EQ(run.validation_log_file(), "/runs/a/validation.jsonl");
  EXPECT_EQ(run.best_scores_file(), "/runs/a/best.json");
  EXPECT_EQ(run.best_checkpoint_file(), "/runs/a/checkpoint-best.fskin");
  EXPECT_EQ(run.lock_file(), "/runs/a/.lock");
}

}  // namespace
}  // namespace fskin
