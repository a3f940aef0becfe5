#include "fskin/training/train_config.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "test_util.h"

namespace fskin {
namespace {

TEST(TrainConfig, RoundTripsAndOverrides) {
  TrainConfig c = TrainConfig::full();
  c.set("steps=17");
  c.set("method=snarf");
  c.set("grid=[8,16,16]");
  const auto back = TrainConfig::from_json(c.to_json(), "test", TrainConfig{});
  EXPECT_EQ(back.steps, 17);
  EXPECT_EQ(back.method, "snarf");
  EXPECT_EQ(back.grid, (std::vector<int64_t>{8, 16, 16}));
  EXPECT_EQ(back.occupancy_hidden_layers, 8);
  EXPECT_EQ(back.to_json(), c.to_json());
}

TEST(TrainConfig, BadInputNamesTheProblem) {
  TrainConfig c;
  testing::expect_error([&] { c.set("stepz=3"); }, {"unknown config key 'stepz'"});
  testing::expect_error([&] { c.set("method=nasa"); }, {"unknown method 'nasa'"});
  testing::expect_error([&] { c.set("steps=\"many\""); }, {"--set steps", "wrong value type"});
  testing::expect_error([&] { c.set("pin_space_output=\"cosine\""); }, {"pin_space_output", "\"cosine\""});
  testing::expect_error([&] { c.set("pin_space_omega=0"); }, {"pin_space_omega"});
  testing::expect_error([&] { c.set("snarf_roots=inside"); }, {"snarf_roots", "\"inside\""});
  testing::expect_error([&] { c.set("implicit_gradient=broyden"); }, {"implicit_gradient", "\"broyden\""});
  testing::expect_error([&] { TrainConfig::from_json("{", "my.json", TrainConfig{}); }, {"my.json", "not valid JSON"});
  for (const auto* bad : {"automatic:abc", "automatic:", "automatic:0", "automatic:99999999999999999999"}) {
    testing::expect_error([&] { c.set(std::string("start_bones=") + bad); }, {"start_bones", bad, "1 to 9999"});
  }
  testing::expect_error([&] { c.set("validate_every=-1"); }, {"validate_every"});
}

TEST(TrainConfig, ShippedConfigsLoad) {
  // configs/*.json overlay the defaults; a renamed key would make them fail.
  const auto ins = TrainConfig::load(std::string(FSKIN_CONFIGS_DIR) + "/ins-paper.json", TrainConfig::full());
  EXPECT_EQ(ins.method, "ins");
  EXPECT_EQ(ins.warmup_steps, 2400);
  EXPECT_DOUBLE_EQ(ins.grad_clip, 4.0);
  EXPECT_FALSE(ins.pose_conditioning);
  // The paper's PINs whatever the base: the CPU defaults differ in every one of these.
  for (const auto& base : {TrainConfig{}, TrainConfig::full()}) {
    const auto paper = TrainConfig::load(std::string(FSKIN_CONFIGS_DIR) + "/ins-paper.json", base);
    EXPECT_EQ(paper.pin_layers, 18);
    EXPECT_EQ(paper.pin_pose_hidden_dim, 128);
    EXPECT_EQ(paper.pin_space_hidden_dim, 64);
    EXPECT_EQ(paper.pin_map_hidden_dim, 32);
    EXPECT_DOUBLE_EQ(paper.pin_space_omega, 30.0);
    EXPECT_EQ(paper.pin_pose_frame, "global");
    EXPECT_EQ(paper.pin_bone_dropout, 0.0);
    EXPECT_DOUBLE_EQ(paper.pin_learning_rate_factor, 0.1);
  }
}

TEST(TrainConfig, MethodDefaultsComeBeforeExplicitSettings) {
  TrainConfig fast;
  fast.use_method("fast-snarf");
  EXPECT_EQ(fast.method, "fast-snarf");
  EXPECT_GT(fast.canonical_sparsity_weight, 0);
  TrainConfig ins;
  ins.use_method("ins");
  EXPECT_EQ(ins.method, "ins");
  EXPECT_EQ(ins.canonical_sparsity_weight, 0);
  EXPECT_DOUBLE_EQ(ins.grad_clip, 4.0);
  EXPECT_DOUBLE_EQ(fast.grad_clip, 0.0);
  ins.set("canonical_sparsity_weight=0.1");  // what a user asks for still wins
  EXPECT_DOUBLE_EQ(ins.canonical_sparsity_weight, 0.1);
}

TEST(TrainConfig, RunConfigsWrittenBeforeAKeyExistedKeepTheirBehaviour) {
  // An INS run saved before pin_space_output existed used the sine output;
  // today's default (linear) would load its checkpoint as a different function.
  auto saved = nlohmann::json::parse(TrainConfig{}.to_json());
  saved.erase("pin_space_output");
  const auto path = testing::temp_dir("old_run_config") / "config.json";
  std::ofstream(path) << saved.dump();
  EXPECT_EQ(TrainConfig::load_run(path.string()).pin_space_output, "sine");
  EXPECT_EQ(TrainConfig::load(path.string(), TrainConfig{}).pin_space_output, "linear");  // an overlay: default
  saved["pin_space_output"] = "linear";
  std::ofstream(path) << saved.dump();
  EXPECT_EQ(TrainConfig::load_run(path.string()).pin_space_output, "linear");
  // Keys whose defaults differ from what runs written without them used.
  for (const auto* key : {"pin_space_omega", "pin_pose_frame", "pin_bone_dropout"}) saved.erase(key);
  std::ofstream(path) << saved.dump();
  const auto old = TrainConfig::load_run(path.string());
  EXPECT_DOUBLE_EQ(old.pin_space_omega, 30.0);
  EXPECT_EQ(old.pin_pose_frame, "global");
  EXPECT_EQ(old.pin_bone_dropout, 0.0);
}

TEST(TrainConfig, BootstrapLastsOneEpoch) {
  TrainConfig c;
  c.frames_per_batch = 8;
  EXPECT_EQ(c.bootstrap_steps(100), 13);
  c.bootstrap_epochs = 0;
  EXPECT_EQ(c.bootstrap_steps(100), 0);
}

}  // namespace
}  // namespace fskin
