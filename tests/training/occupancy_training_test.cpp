#include "fskin/training/occupancy_training.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "fskin/engine/checkpoint.h"
#include "fskin/engine/run_lock.h"
#include "fskin/evaluation/evaluation.h"
#include "test_util.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;
using testing::log_column;
using testing::mean;
using testing::SyntheticLimb;
using testing::tiny_config;
using testing::training_angles;

TEST(Trainer, LossFallsAndIouRisesAboveChance) {
  const SyntheticLimb limb(training_angles());
  const auto run = testing::temp_dir("trainer_learns");
  TrainConfig config = tiny_config();
  config.steps = 400;
  config.checkpoint_every = 100;
  const auto result = train(config, limb, {run.string(), false, false, nullptr});
  EXPECT_EQ(result.last_step, 400);
  const auto bce = log_column(run, "bce");
  ASSERT_EQ(bce.size(), 400u);
  EXPECT_LT(mean(bce, 350, 400), 0.5 * mean(bce, 0, 50));

  const auto frames = SyntheticLimb::frames({-1.0, 0.3, 1.1}, 2000, 2000);
  auto model = load_trained_model(run.string(), limb.skeleton());
  const auto metrics = evaluate(*model, frames, "test");
  // Chance: calling everything inside scores the occupied fraction.
  double occupied = 0;
  for (const auto& f : frames) occupied += f.occupancy.slice(0, 0, 2000).mean().item<double>() / frames.size();
  EXPECT_GT(metrics.mean_iou_bbox, occupied + 0.3) << metrics.table();
  std::printf("%s", metrics.table().c_str());
  EXPECT_GT(metrics.mean_iou_surf, 0.6) << metrics.table();
  EXPECT_EQ(metrics.frames.size(), 3u);
  EXPECT_NE(metrics.to_json().find("mean_iou_surf"), std::string::npos);
}

void expect_same_parameters(OccupancyModel& a, OccupancyModel& b) {
  const auto pa = a.named_parameters(), pb = b.named_parameters();
  ASSERT_EQ(pa.size(), pb.size());
  for (const auto& item : pa) {
    EXPECT_TRUE(torch::equal(item.value(), pb[item.key()])) << item.key();
  }
}

// Pose-conditioned Fast-SNARF, and INS with bone dropout: the model's own
// random draws (from the per-step seeded default generator) must repeat too.
TrainConfig resume_config(const std::string& method) {
  TrainConfig config = tiny_config();
  config.steps = 8;
  config.checkpoint_every = 2;
  config.method = method;
  config.pose_conditioning = method != "ins";
  config.pin_layers = 2;
  config.pin_pose_hidden_dim = 8;
  config.pin_space_hidden_dim = 8;
  config.pin_map_hidden_dim = 8;
  config.pin_bone_dropout = 0.5;
  return config;
}

class TrainerResume : public ::testing::TestWithParam<std::string> {};

TEST_P(TrainerResume, EqualsUninterrupted) {
  const SyntheticLimb limb(training_angles());
  const TrainConfig config = resume_config(GetParam());
  const auto whole = testing::temp_dir("trainer_whole");
  train(config, limb, {whole.string(), false, false, nullptr});

  const auto split = testing::temp_dir("trainer_split");
  TrainConfig half = config;
  half.steps = 3;  // stops between checkpoints: the exit checkpoint carries step 3
  train(half, limb, {split.string(), false, false, nullptr});
  const auto resumed = train(config, limb, {split.string(), true, false, nullptr});
  EXPECT_EQ(resumed.first_step, 3);
  EXPECT_EQ(resumed.last_step, 8);
  EXPECT_EQ(log_column(split, "step").size(), 8u);

  int64_t step_a = 0, step_b = 0;
  auto a = load_trained_model(whole.string(), limb.skeleton(), &step_a);
  auto b = load_trained_model(split.string(), limb.skeleton(), &step_b);
  EXPECT_EQ(step_a, 8);
  EXPECT_EQ(step_b, 8);
  expect_same_parameters(*a, *b);
  EXPECT_EQ(log_column(whole, "bce"), log_column(split, "bce"));
}

// A run killed after writing its config but before its first checkpoint:
// --resume starts it from step 0 and ends where an uninterrupted run ends.
TEST(Trainer, ResumeBeforeTheFirstCheckpointTrainsFromTheStart) {
  const SyntheticLimb limb(training_angles());
  const TrainConfig config = resume_config("fast-snarf");
  const auto whole = testing::temp_dir("trainer_whole_early");
  train(config, limb, {whole.string(), false, false, nullptr});

  const auto early = testing::temp_dir("trainer_killed_early");
  std::ofstream(early / "config.json") << config.to_json();  // what a kill before step 1 leaves
  const auto resumed = train(config, limb, {early.string(), true, false, nullptr});
  EXPECT_EQ(resumed.first_step, 0);
  EXPECT_EQ(resumed.last_step, 8);
  int64_t step_a = 0, step_b = 0;
  auto a = load_trained_model(whole.string(), limb.skeleton(), &step_a);
  auto b = load_trained_model(early.string(), limb.skeleton(), &step_b);
  EXPECT_EQ(step_b, 8);
  expect_same_parameters(*a, *b);
  EXPECT_EQ(log_column(whole, "bce"), log_column(early, "bce"));
}

// Delegates to a source and poisons the targets of every batch from the
// `poisoned_from`-th on with NaN: a diverging run, on demand.
class PoisonedSource : public BatchSource {
 public:
  PoisonedSource(const BatchSource& source, int64_t poisoned_from) : source_(source), poisoned_from_(poisoned_from) {}
  int64_t num_frames() const override { return source_.num_frames(); }
  const CanonicalSkeleton& skeleton() const override { return source_.skeleton(); }
  OccupancyBatch batch(int64_t frames, int64_t surface_points, int64_t uniform_points, uint64_t seed) const override {
    auto batch = source_.batch(frames, surface_points, uniform_points, seed);
    if (++batches_ > poisoned_from_) batch.occupancy = torch::full_like(batch.occupancy, std::nanf(""));
    return batch;
  }

 private:
  const BatchSource& source_;
  int64_t poisoned_from_;
  mutable int64_t batches_ = 0;
};

TEST(Trainer, ANonFiniteLossStopsTrainingAndKeepsTheLastGoodCheckpoint) {
  const SyntheticLimb limb(training_angles());
  TrainConfig config = resume_config("fast-snarf");
  config.checkpoint_every = 2;
  const PoisonedSource diverging(limb, 5);
  const auto run = testing::temp_dir("trainer_nan");
  testing::expect_error([&] { train(config, diverging, {run.string(), false, false, nullptr}); },
                        {run.string(), "the loss became nan at step 6", "last checkpoint (step 4) is kept"});
  int64_t step = 0;
  load_trained_model(run.string(), limb.skeleton(), &step);
  EXPECT_EQ(step, 4);
  // The run resumes from there once the cause is gone.
  const auto resumed = train(config, limb, {run.string(), true, false, nullptr});
  EXPECT_EQ(resumed.first_step, 4);
  EXPECT_EQ(resumed.last_step, config.steps);
}

// One writer per run: a second training into a run another process writes
// fails at once, naming it.
TEST(Trainer, ARunAnotherWriterHoldsIsRefused) {
  const SyntheticLimb limb(training_angles());
  const auto run = testing::temp_dir("trainer_locked");
  const RunLock holder(run.string());
  testing::expect_error([&] { train(resume_config("fast-snarf"), limb, {run.string(), false, false, nullptr}); },
                        {run.string(), "another fskin process", "PID"});
  EXPECT_FALSE(fs::exists(run / "config.json"));
}

INSTANTIATE_TEST_SUITE_P(Methods, TrainerResume, ::testing::Values("fast-snarf", "ins"),
                         [](const auto& info) { return info.param == "fast-snarf" ? "fast_snarf" : info.param; });

// A seed and a thread count fix a run: its log and its parameters repeat
// exactly. (Across thread counts the reductions are split differently and the
// runs part in the last digits, then further; docs/benchmarks.md#seeds-and-threads.)
TEST(Trainer, RepeatsExactlyForASeedAndAThreadCount) {
  const SyntheticLimb limb(training_angles());
  TrainConfig config = resume_config("fast-snarf");
  config.seed = 7;
  const int previous = at::get_num_threads();
  for (const int threads : {1, 2}) {
    at::set_num_threads(threads);
    const auto a = testing::temp_dir("trainer_repeat_a"), b = testing::temp_dir("trainer_repeat_b");
    train(config, limb, {a.string(), false, false, nullptr});
    train(config, limb, {b.string(), false, false, nullptr});
    EXPECT_EQ(log_column(a, "loss"), log_column(b, "loss")) << threads << " threads";
    auto model_a = load_trained_model(a.string(), limb.skeleton());
    auto model_b = load_trained_model(b.string(), limb.skeleton());
    expect_same_parameters(*model_a, *model_b);
  }
  at::set_num_threads(previous);
}

TEST(Trainer, TruncatedNewestCheckpointFallsBackToThePrevious) {
  const SyntheticLimb limb(training_angles());
  TrainConfig config = tiny_config();
  config.steps = 6;
  config.checkpoint_every = 3;
  const auto reference = testing::temp_dir("trainer_reference");
  train(config, limb, {reference.string(), false, false, nullptr});

  const auto damaged = testing::temp_dir("trainer_damaged");
  train(config, limb, {damaged.string(), false, false, nullptr});
  const auto checkpoints = list_checkpoints(damaged.string());
  ASSERT_EQ(checkpoints.size(), 2u);
  fs::resize_file(checkpoints.front(), fs::file_size(checkpoints.front()) / 2);  // a kill mid-copy
  int64_t step = 0;
  load_trained_model(damaged.string(), limb.skeleton(), &step);
  EXPECT_EQ(step, 3);
  // Resuming redoes steps 4..6 and lands exactly where the intact run did.
  const auto resumed = train(config, limb, {damaged.string(), true, false, nullptr});
  EXPECT_EQ(resumed.first_step, 3);
  auto a = load_trained_model(reference.string(), limb.skeleton());
  auto b = load_trained_model(damaged.string(), limb.skeleton());
  expect_same_parameters(*a, *b);
}

TEST(Trainer, CheckpointWithOtherOptimizerGroupsIsRefusedOnResume) {
  // Written like fskin before the skinning network had its own learning rate:
  // one optimizer group for every parameter.
  const SyntheticLimb limb(training_angles());
  TrainConfig config = tiny_config();
  config.steps = 2;
  config.checkpoint_every = 2;
  const auto run = testing::temp_dir("trainer_one_group");
  train(config, limb, {run.string(), false, false, nullptr});
  auto model = load_trained_model(run.string(), limb.skeleton());
  torch::optim::Adam one_group(model->parameters(), torch::optim::AdamOptions(1e-3));
  const auto path = save_checkpoint(
      run.string(), 2,
      [&](torch::serialize::OutputArchive& archive) {
        torch::serialize::OutputArchive model_archive, optimizer_archive;
        model->save(model_archive);
        one_group.save(optimizer_archive);
        archive.write("model", model_archive);
        archive.write("optimizer", optimizer_archive);
        archive.write("step", torch::tensor(int64_t{2}));
      },
      1);
  load_trained_model(run.string(), limb.skeleton());  // evaluation still reads it
  config.steps = 4;
  testing::expect_error([&] { train(config, limb, {run.string(), true, false, nullptr}); },
                        {path, "optimizer state does not match", "2 parameter groups", "not resumed"});
}

TEST(Trainer, StopSignalCheckpointsAndReturns) {
  const SyntheticLimb limb(training_angles());
  TrainConfig config = tiny_config();
  config.steps = 5;
  const auto run = testing::temp_dir("trainer_stop");
  StopSignal stop;
  StopSignal::request();
  const auto result = train(config, limb, {run.string(), false, false, &stop});
  EXPECT_TRUE(result.stopped);
  EXPECT_EQ(result.last_step, 0);
  EXPECT_EQ(list_checkpoints(run.string()).size(), 1u);
  testing::expect_error([&] { load_trained_model((run / "nothing").string(), limb.skeleton()); }, {"nothing"});
}

TEST(Trainer, KeepsTheBestCheckpointOnTheValidationFrames) {
  const SyntheticLimb limb(training_angles());
  TrainConfig config = tiny_config();
  config.steps = 60;
  config.checkpoint_every = 20;
  config.keep_checkpoints = 1;
  config.validate_every = 15;
  const auto validation = SyntheticLimb::frames({-0.8, 0.4}, 500, 500);
  const auto run = testing::temp_dir("trainer_best");
  testing::expect_error([&] { train(config, limb, {run.string(), false, false, nullptr}); },
                        {"validate_every = 15", "no validation frames"});
  const auto result = train(config, limb, {run.string(), false, false, nullptr, &validation});

  // One row per validation, and the best one is what best.json and the result name.
  std::ifstream rows(run / "validation.jsonl");
  std::vector<std::pair<int64_t, double>> scores;
  for (std::string line; std::getline(rows, line);) {
    const auto j = nlohmann::json::parse(line);
    scores.emplace_back(j.at("step").get<int64_t>(), j.at("iou_surf").get<double>());
  }
  ASSERT_EQ(scores.size(), 4u);  // steps 15, 30, 45, 60
  auto best = scores.front();
  for (const auto& s : scores) {
    if (s.second > best.second) best = s;
  }
  EXPECT_EQ(result.best_step, best.first);
  EXPECT_DOUBLE_EQ(result.best_iou_surf, best.second);
  const auto best_json = nlohmann::json::parse(std::ifstream(run / "best.json"));
  EXPECT_EQ(best_json.at("step").get<int64_t>(), best.first);

  // --checkpoint best loads that step, and it scores what was recorded; the
  // numbered rotation (keep 1) holds only the last step.
  int64_t step = 0;
  auto model = load_trained_model(run.string(), limb.skeleton(), &step, CheckpointChoice::parse("best"));
  EXPECT_EQ(step, best.first);
  EXPECT_DOUBLE_EQ(evaluate(*model, validation, "val").mean_iou_surf, best.second);
  load_trained_model(run.string(), limb.skeleton(), &step);
  EXPECT_EQ(step, 60);
  if (best.first != 60) {
    testing::expect_error(
        [&] { load_trained_model(run.string(), limb.skeleton(), &step, CheckpointChoice{CheckpointChoice::Kind::Step, best.first}); },
        {"no checkpoint of step"});
  }
}

TEST(LearningRateSchedule, WarmsUpHoldsThenDecaysByCosineToTheFactor) {
  TrainConfig config;
  config.steps = 100;
  config.warmup_steps = 10;
  config.warmup_factor = 0.2;
  config.decay_fraction = 0.4;
  config.decay_factor = 0.1;
  EXPECT_DOUBLE_EQ(learning_rate_scale(config, 0), 0.2);
  EXPECT_DOUBLE_EQ(learning_rate_scale(config, 5), 0.6);
  EXPECT_DOUBLE_EQ(learning_rate_scale(config, 10), 1.0);
  EXPECT_DOUBLE_EQ(learning_rate_scale(config, 60), 1.0);  // the decay starts after step 60
  EXPECT_NEAR(learning_rate_scale(config, 80), 0.55, 1e-12);  // half-way: the cosine's midpoint
  EXPECT_NEAR(learning_rate_scale(config, 100), 0.1, 1e-12);
  for (int64_t step = 61; step <= 100; ++step) {
    EXPECT_LT(learning_rate_scale(config, step), learning_rate_scale(config, step - 1)) << step;
  }
  config.decay_fraction = 0;
  EXPECT_DOUBLE_EQ(learning_rate_scale(config, 99), 1.0);
}

}  // namespace
}  // namespace fskin
