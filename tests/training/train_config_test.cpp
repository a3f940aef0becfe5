#include "fskin/training/train_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include "fskin/body/smpl_skeleton.h"
#include "fskin/core/error.h"
#include "fskin/training/config_schema.h"
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
  testing::expect_error([&] { c.set("steps=\"many\""); }, {"--set steps", "steps: must be a whole number", "\"many\""});
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

TEST(TrainConfig, DocumentsAreNestedPerComponentWithTypes) {
  TrainConfig c;
  c.set("model.deformer.grid.resolution=40");
  c.set("occupancy_hash_levels=8");  // a flat name still works, and selects the hash encoding
  const auto doc = nlohmann::json::parse(c.to_json());
  EXPECT_EQ(doc.at("model").at("type"), "fast-snarf");
  EXPECT_EQ(doc.at("model").at("deformer").at("grid").at("resolution"), 40);
  EXPECT_EQ(doc.at("model").at("canonical").at("encoding").at("type"), "frequency+hash");
  EXPECT_EQ(doc.at("model").at("canonical").at("encoding").at("hash").at("levels"), 8);
  EXPECT_EQ(doc.at("optimizer").at("type"), "adam");
  EXPECT_EQ(doc.at("schedule").at("type"), "warmup-cosine");
  EXPECT_EQ(doc.at("losses").at("canonical_sparsity").at("weight"), 0.3);
  EXPECT_FALSE(doc.contains("grid_resolution"));
  // Every key appears once, at its path.
  for (const auto& key : config_keys()) {
    const auto pointer = "/" + std::regex_replace(key.path, std::regex("\\."), "/");
    EXPECT_TRUE(doc.contains(nlohmann::json::json_pointer(pointer))) << key.path;
  }
  // The nested and the flat document describe the same config.
  const auto from_nested = TrainConfig::from_json(c.to_json(), "nested", TrainConfig::full());
  const auto from_flat = TrainConfig::from_json(c.to_flat_json(), "flat", TrainConfig::full());
  EXPECT_EQ(from_nested.to_json(), c.to_json());
  EXPECT_EQ(from_flat.to_json(), c.to_json());
  // The encoding's type, given, decides the hash levels.
  c.set(R"(model.canonical.encoding={"type": "frequency"})");
  EXPECT_EQ(c.occupancy_hash_levels, 0);
}

TEST(TrainConfig, ErrorsNameTheKeyPath) {
  TrainConfig c;
  testing::expect_error([&] { c.set("model.deformer.grid.resolution=2"); },
                        {"--set model.deformer.grid.resolution=2", "model.deformer.grid.resolution:",
                         "from 4 to 1024", "got 2"});
  testing::expect_error([&] { c.set("grid_resolution=2"); }, {"model.deformer.grid.resolution:", "got 2"});
  testing::expect_error([&] { c.set("model.deformer.grid.resolutoin=40"); },
                        {"unknown config key 'model.deformer.grid.resolutoin'"});
  testing::expect_error([&] { c.set("model.grid_resolution=40"); }, {"unknown config key 'model.grid_resolution'"});
  testing::expect_error([&] { c.set("optimizer.type=sgd"); }, {"optimizer.type", "\"adam\"", "\"sgd\""});
  testing::expect_error([&] { c.set("model.canonical.encoding.type=fourier"); },
                        {"model.canonical.encoding.type", "\"fourier\""});
  testing::expect_error([&] { c.set("model.canonical.encoding.type=frequency+hash"); },
                        {"needs model.canonical.encoding.hash.levels >= 1"});
  testing::expect_error([&] { c.set("model.canonical.network.skip_layers=[1.5]"); },
                        {"model.canonical.network.skip_layers", "whole numbers"});
  testing::expect_error([&] { c.set("data.surface_points=0"); c.set("data.uniform_points=0"); },
                        {"data.surface_points + data.uniform_points", "empty"});
  testing::expect_error([&] { TrainConfig::from_json(R"({"data": {"frames_per_batch": 0}})", "cfg.json", TrainConfig{}); },
                        {"cfg.json: data.frames_per_batch: must be >= 1, got 0"});
  testing::expect_error(
      [&] { TrainConfig::from_json(R"({"grid_resolution": 40, "model": {"deformer": {"grid": {"resolution": 48}}}})",
                                   "twice.json", TrainConfig{}); },
      {"twice.json", "model.deformer.grid.resolution is given twice"});
  testing::expect_error([&] { c.set("learning_rate=2"); }, {"optimizer.learning_rate", "(0, 1]", "got 2"});
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
  auto saved = nlohmann::json::parse(TrainConfig{}.to_flat_json());  // runs of that time were flat
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
  // Runs written before grid_resolution kept their explicit grid, in the person layout.
  saved.erase("grid_resolution");
  std::ofstream(path) << saved.dump();
  EXPECT_EQ(TrainConfig::load_run(path.string()).grid_resolution, 0);
}

CanonicalSkeleton skeleton_of(std::vector<std::string> names, const torch::Tensor& extent) {
  CanonicalSkeleton s;
  s.joint_names = std::move(names);
  for (size_t j = 0; j < s.joint_names.size(); ++j) s.parents.push_back(static_cast<int64_t>(j) - 1);
  s.joints = torch::zeros({static_cast<int64_t>(s.joint_names.size()), 3});
  s.extent = extent;
  return s;
}

TEST(TrainConfig, DefaultsFollowTheSkeletonNotAPerson) {
  // A long animal lying along z, 4 m long, with names fskin does not know.
  std::vector<std::string> names;
  for (int j = 0; j < 12; ++j) names.push_back("Bone." + std::to_string(j));
  const auto extent = torch::tensor({{-0.3, 0.0, -2.0}, {0.3, 0.8, 2.0}});
  const auto options = model_options(TrainConfig{}, skeleton_of(names, extent));
  const auto& f = options.forward_skinning;
  EXPECT_EQ(f.deformer.start_bones.mode, StartBones::Mode::Automatic);
  EXPECT_EQ(f.deformer.start_bones.count, 9);
  // The grid lies along z, 32 voxels along the 4 m, covering the whole body.
  EXPECT_EQ(f.box.shape.depth, 32);
  EXPECT_LE(f.box.shape.width, 9);  // 0.6 m + 2 x 5 % padding of 4 m, near-cubic voxels
  EXPECT_TRUE(f.box.contains(extent).all().item<bool>());
  EXPECT_EQ(fraction_outside_grid(options, skeleton_of(names, extent)), 0.0);
  // Broyden's thresholds are lengths: for a 4 m body (4 / 1.7) x the papers'.
  EXPECT_NEAR(f.deformer.converge_sq, 1e-8 * std::pow(4.0 / 1.7, 2), 1e-15);
  EXPECT_NEAR(f.deformer.duplicate_distance, 1e-4 * 4.0 / 1.7, 1e-12);

  // SMPL's names keep the papers' 9 start bones.
  const auto smpl = model_options(TrainConfig{}, skeleton_of(smpl_joint_names(), extent));
  EXPECT_EQ(smpl.forward_skinning.deformer.start_bones.mode, StartBones::Mode::Subset);
  EXPECT_EQ(smpl.forward_skinning.deformer.start_bones.indices.size(), 9u);
  // The explicit SMPL list on another skeleton names the missing joint.
  TrainConfig c;
  c.start_bones = "smpl-training";
  testing::expect_error([&] { model_options(c, skeleton_of(names, extent)); }, {"pelvis", "automatic:K"});
  // grid_resolution 0: the explicit grid in the papers' person layout.
  c = TrainConfig{};
  c.grid_resolution = 0;
  const auto legacy_options = model_options(c, skeleton_of(names, extent));
  const auto& legacy = legacy_options.forward_skinning.box;
  EXPECT_EQ(legacy.shape.depth, 8);
  EXPECT_FALSE(legacy.contains(extent).all().item<bool>());  // why it is no longer the default
  // ... and what training warns about (the extent's two corners: both out).
  EXPECT_GT(fraction_outside_grid(legacy_options, skeleton_of(names, extent)), 0.4);
  testing::expect_error([&] { c.set("grid_resolution=2"); }, {"grid_resolution"});
}

// Every key of the config given every kind of bad value (as `--set` would):
// accepted, or rejected with fskin::Error naming the key, also when the model
// is then made from it; never another exception.
TEST(TrainConfig, EveryKeyWithABadValueIsAnFskinError) {
  const std::vector<std::string> values = {"",      "abc",   "-1",    "0",      "1e308", "nan",          "inf",
                                           "-inf",  "[1,2]", "{}",    "999999999999999999999", "true", "0.5",
                                           "automatic:abc", "automatic:0", "automatic:-3", "all", "\"x\"", "null"};
  std::vector<std::string> names;
  for (int j = 0; j < 5; ++j) names.push_back("j" + std::to_string(j));
  const auto skeleton = skeleton_of(names, torch::tensor({{-1.0, -1.0, -1.0}, {1.0, 1.0, 1.0}}));
  int64_t accepted = 0, rejected = 0;
  std::vector<std::string> internal;
  for (const auto& key : config_keys())
    for (const auto& value : values) {
      const std::string assignment = key.path + "=" + value;
      try {
        TrainConfig c;
        c.set(assignment);
        c.validate();
        model_options(c, skeleton);
        ++accepted;
      } catch (const Error&) {
        ++rejected;
      } catch (const std::exception& e) {
        internal.push_back(assignment + ": " + std::string(e.what()).substr(0, 200));
      }
    }
  std::string examples;
  for (size_t i = 0; i < internal.size() && i < 8; ++i) examples += "\n  " + internal[i];
  EXPECT_TRUE(internal.empty()) << internal.size() << " assignments raised a non-fskin error:" << examples;
  EXPECT_GT(rejected, accepted);
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
