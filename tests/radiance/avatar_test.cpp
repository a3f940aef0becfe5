#include "fskin/radiance/avatar.h"

#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <torch/torch.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "fskin/geometry/character_size.h"
#include "fskin/import/gltf_import.h"
#include "fskin/radiance/avatar_config.h"
#include "fskin/radiance/avatar_evaluation.h"
#include "fskin/radiance/avatar_export.h"
#include "fskin/radiance/avatar_mesh.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/image_metrics.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"
#include "tiny_image_dataset.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

using testing::small_avatar;
using testing::tiny_training;

// The field made constant: density exp(raw) / extent and colour sigmoid(.) everywhere in its box.
void make_field_constant(Avatar& avatar, double raw_sigma, std::array<double, 3> raw_rgb) {
  torch::NoGradGuard no_grad;
  auto parameters = avatar->named_parameters();
  const auto* weight = parameters.find("field.mlp.4.weight");
  const auto* bias = parameters.find("field.mlp.4.bias");
  ASSERT_TRUE(weight && bias);
  weight->zero_();
  bias->copy_(torch::tensor({raw_sigma, raw_rgb[0], raw_rgb[1], raw_rgb[2]}, torch::kFloat32));
}

TEST(Avatar, RendersTheAnalyticOpacityOfAConstantField) {
  const auto& tiny = testing::tiny_image_dataset();
  const ImageDataset data(tiny.dir);
  Avatar avatar(data.character(), small_avatar());
  const auto lo = avatar->canonical_lower(), hi = avatar->canonical_upper();
  const double length = hi[0] - lo[0];
  // sigma * length = 1 along a ray crossing the box along x.
  double extent = 0;
  for (int c = 0; c < 3; ++c) extent = std::max(extent, hi[c] - lo[c]);
  const double sigma = 1.0 / length;
  make_field_constant(avatar, std::log(sigma * extent), {0.0, 1.0, -1.0});
  const double opacity = 1 - std::exp(-sigma * length);
  const double red = 0.5, green = 1 / (1 + std::exp(-1.0)), blue = 1 / (1 + std::exp(1.0));
  const Eigen::Vector3d centre(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2]));

  // In the canonical pose, and after one rigid motion of every bone (LBS is then
  // that motion): the same ray in the moved frame sees the same field.
  const int64_t J = data.character().num_joints();
  const auto identity = torch::eye(4).expand({J, 4, 4}).contiguous();
  auto motion = torch::eye(4);
  const double angle = 0.7;
  motion[0][0] = std::cos(angle), motion[0][1] = -std::sin(angle), motion[1][0] = std::sin(angle),
  motion[1][1] = std::cos(angle);
  motion[0][3] = 0.3, motion[1][3] = -0.2, motion[2][3] = 1.5;
  for (const auto& bones : {identity, motion.matmul(identity).contiguous()}) {
    const auto frame = avatar->pose(bones);
    // Two rays along x through the centre (one reversed), one missing the box.
    auto origins = torch::tensor({{lo[0] - 0.5, centre.y(), centre.z()},
                                  {hi[0] + 0.5, centre.y() + 0.01, centre.z()},
                                  {lo[0] - 0.5, hi[1] + 0.5, centre.z()}},
                                 torch::kFloat32);
    auto directions = torch::tensor({{1.0, 0.0, 0.0}, {-1.0, 0.0, 0.0}, {1.0, 0.0, 0.0}}, torch::kFloat32);
    const auto rotation = bones[0].slice(0, 0, 3).slice(1, 0, 3);
    origins = transform_points(bones[0], origins);
    directions = directions.matmul(rotation.transpose(0, 1));
    const auto rendered = avatar->render_rays(frame, origins, directions, torch::zeros({3, 3}), false);
    for (int r = 0; r < 2; ++r) {
      EXPECT_NEAR(rendered.opacity[r].item<double>(), opacity, 0.02) << r;
      EXPECT_NEAR(rendered.color[r][0].item<double>(), red * opacity, 0.02);
      EXPECT_NEAR(rendered.color[r][1].item<double>(), green * opacity, 0.02);
      EXPECT_NEAR(rendered.color[r][2].item<double>(), blue * opacity, 0.02);
    }
    EXPECT_NEAR(rendered.opacity[2].item<double>(), 0.0, 1e-6);
    EXPECT_GT(rendered.samples, 0);
  }
}

TEST(Avatar, EmptyCanonicalSpaceRendersTheBackground) {
  const auto& tiny = testing::tiny_image_dataset();
  const ImageDataset data(tiny.dir);
  Avatar avatar(data.character(), small_avatar());
  make_field_constant(avatar, -30.0, {0.0, 0.0, 0.0});  // no density anywhere
  avatar->update_canonical_occupancy();
  EXPECT_EQ(avatar->canonical_grid().occupied_fraction(), 0.0);
  const auto split = data.load_split("train");
  const auto frame = avatar->pose(split.bone_transforms[0]);
  EXPECT_EQ(frame.grid.occupied_fraction(), 0.0);
  const auto [rgb, opacity] = avatar->render_image(frame, split.cameras[0], {0.2, 0.4, 0.6});
  EXPECT_TRUE(torch::allclose(rgb.select(2, 1), torch::full({40, 40}, 0.4f)));
  EXPECT_EQ(opacity.max().item<float>(), 0.0f);
}

TEST(AvatarTraining, RaisesPsnrResumesAndMeshes) {
  const auto& tiny = testing::tiny_image_dataset();
  auto options = tiny_training("avatar_training", 150, 1024);
  options.images_per_step = 2;
  options.checkpoint_every = 100;
  options.occupancy_every = 25;
  options.occupancy_warmup = 50;
  options.decay_fraction = 0;  // a constant learning rate: the most progress in 150 steps

  const ImageDataset data(tiny.dir);
  Avatar untrained(data.character(), options.avatar);
  const auto before = evaluate_avatar(untrained, data, "train", 0, false);

  auto partial = options;
  partial.steps = 100;
  const auto first = train_avatar(partial);
  EXPECT_EQ(first.last_step, 100);
  // Continuing needs --resume; with it the run goes on from its checkpoint.
  testing::expect_error([&] { train_avatar(options); }, {"--resume"});
  options.resume = true;
  const auto second = train_avatar(options);
  EXPECT_EQ(second.first_step, 100);
  EXPECT_EQ(second.last_step, 150);

  auto trained = TrainedAvatar::load(options.out_dir);
  EXPECT_EQ(trained.step, 150);
  const auto after = evaluate_avatar(trained.avatar, data, "train", 0, false);
  const auto novel = evaluate_avatar(trained.avatar, data, "novel_pose", 0, false);
  EXPECT_GT(after.mean_psnr, before.mean_psnr + 5) << before.mean_psnr << " -> " << after.mean_psnr;
  EXPECT_GT(after.mean_psnr, 23.0);
  EXPECT_GT(novel.mean_psnr, 18.0);
  EXPECT_GT(after.mean_ssim, before.mean_ssim);
  EXPECT_NE(after.to_json().find("\"mean_psnr\""), std::string::npos);

  // The learned surface, coloured, and posed like a held-out image.
  const auto novel_split = data.load_split("novel_pose");
  const Mesh canonical = avatar_mesh(trained.avatar, 48);
  const Mesh posed = avatar_mesh(trained.avatar, 48, novel_split.bone_transforms[0]);
  ASSERT_GT(canonical.num_faces(), 100);
  EXPECT_EQ(posed.num_vertices(), canonical.num_vertices());
  EXPECT_TRUE(canonical.colors.defined());
  EXPECT_FALSE(torch::allclose(posed.vertices, canonical.vertices));

  // As a rigged glTF asset with every influence: a player posing it with its
  // animation moves its vertices as the avatar's deformer does; its colours
  // are COLOR_0.
  const auto bones = novel_split.bone_transforms;
  auto rigged = rigged_image_avatar(trained.avatar, data.character().skeleton, 48, bones, 10);
  rigged.influences = 0;
  const auto glb = (testing::temp_dir("avatar_export") / "avatar.glb").string();
  write_skinned_gltf(glb, rigged);
  const auto imported = import_gltf(glb, {/*keep_open_parts=*/true});
  ASSERT_EQ(imported.clips.size(), 1u);
  const BodyModel player(imported.model, glb);
  EXPECT_EQ(player.num_joints(), data.character().num_joints());
  const auto& clip = imported.clips[0].poses;
  ASSERT_EQ(clip.size(), bones.size(0));
  const auto played = player.pose(clip.poses, {}, clip.trans).vertices;
  torch::NoGradGuard no_grad;
  const auto rest = imported.model.v_template.to(torch::kFloat32);
  const auto expected = trained.avatar->deformer().deform(rest.unsqueeze(0).expand({bones.size(0), -1, -1}).contiguous(),
                                                          bones);
  const double size = character_size(rest);
  EXPECT_LT((played - expected).abs().max().item<double>(), 1e-4 * size);
  tinygltf::Model model;
  std::string error, warning;
  ASSERT_TRUE(tinygltf::TinyGLTF().LoadBinaryFromFile(&model, &error, &warning, glb)) << error;
  const auto& attributes = model.meshes.at(0).primitives.at(0).attributes;
  ASSERT_TRUE(attributes.count("COLOR_0"));
  EXPECT_EQ(model.accessors[attributes.at("COLOR_0")].count, model.accessors[attributes.at("POSITION")].count);
}

TEST(AvatarTraining, StopsOnCtrlCWithACheckpoint) {
  auto options = tiny_training("avatar_stop", 1000, 64);
  StopSignal stop;
  options.stop = &stop;
  StopSignal::request();  // as the first Ctrl-C does
  const auto summary = train_avatar(options);
  EXPECT_TRUE(summary.stopped);
  EXPECT_LT(summary.last_step, 1000);
  EXPECT_EQ(TrainedAvatar::load(options.out_dir).step, summary.last_step);
}

TEST(AvatarTraining, RejectsBadOptionsAndRuns) {
  AvatarTrainOptions options;
  options.data_dir = "x";
  options.out_dir = "y";
  options.background = "green";
  testing::expect_error([&] { options.validate(); }, {"background", "green"});
  testing::expect_error([] { TrainedAvatar::load("/nonexistent/run"); }, {"/nonexistent/run", "avatar.json"});
}

TEST(AvatarTraining, DamagedRunSettingsAreNamed) {
  auto options = tiny_training("avatar_damaged", 1, 64);
  train_avatar(options);
  const auto config = (fs::path(options.out_dir) / "avatar.json").string();
  const std::string text = read_file(config);
  write_file_atomically(config, text.substr(0, text.size() / 2));  // cut by a crash of another program
  testing::expect_error([&] { TrainedAvatar::load(options.out_dir); }, {config, "parse"});
  auto j = nlohmann::json::parse(text);
  j["model"]["field"]["encoding"]["levels"] = 0;
  write_file_atomically(config, j.dump());
  testing::expect_error([&] { TrainedAvatar::load(options.out_dir); }, {config, "levels"});
  options.resume = true;
  testing::expect_error([&] { train_avatar(options); }, {config, "levels"});
  j["model"]["field"]["encoding"]["levels"] = "many";
  write_file_atomically(config, j.dump());
  testing::expect_error([&] { TrainedAvatar::load(options.out_dir); },
                        {config, "model.field.encoding.levels: must be a whole number, got \"many\""});
  j["model"]["field"]["encoding"]["levels"] = 4;
  j["model"]["field"]["width"] = 4;
  write_file_atomically(config, j.dump());
  testing::expect_error([&] { TrainedAvatar::load(options.out_dir); }, {config, "model.field.width: unknown key"});
}

TEST(AvatarTraining, RunSettingsAreNestedPerComponentAndFlatOnesStillLoad) {
  auto options = tiny_training("avatar_nested", 1, 64);
  options.avatar.field.hidden_dim = 24;
  options.huber_delta = 0.2;
  train_avatar(options);
  const auto config = (fs::path(options.out_dir) / "avatar.json").string();
  const auto nested = nlohmann::json::parse(read_file(config));
  EXPECT_EQ(nested.at("format"), "fskin-avatar-run");
  EXPECT_EQ(nested.at("model").at("type"), "fast-snarf-avatar");
  EXPECT_EQ(nested.at("model").at("field").at("network").at("hidden_dim"), 24);
  EXPECT_EQ(nested.at("losses").at("colour").at("huber_delta"), 0.2);
  EXPECT_EQ(nested.at("optimizer").at("type"), "adam");
  // The flat layout of runs written before the nested one.
  const nlohmann::json flat = {{"format", "fskin-avatar-run"},
                               {"data_dir", options.data_dir},
                               {"encoding", nested.at("model").at("field").at("encoding")},
                               {"hidden_dim", 24},
                               {"huber_delta", 0.2},
                               {"steps", 1}};
  const auto from_flat = avatar_options_from_document(flat, TrainedAvatar::load(options.out_dir).options, "flat");
  EXPECT_EQ(from_flat.avatar.field.hidden_dim, 24);
  EXPECT_EQ(from_flat.huber_delta, 0.2);
  write_file_atomically(config, flat.dump());
  EXPECT_EQ(TrainedAvatar::load(options.out_dir).options.avatar.field.hidden_dim, 24);

  // --set a.b.c=v: typed, checked against the defaults' keys, validated.
  AvatarTrainOptions set = options;
  set_avatar_option(set, "model.occupancy_grid.every=7");
  set_avatar_option(set, "data.background=white");
  EXPECT_EQ(set.occupancy_every, 7);
  EXPECT_EQ(set.background, "white");
  testing::expect_error([&] { set_avatar_option(set, "model.occupancy_grid.every=0"); },
                        {"--set model.occupancy_grid.every=0", "intervals must be >= 1"});
  testing::expect_error([&] { set_avatar_option(set, "model.grid.every=3"); },
                        {"model.grid: unknown key", "occupancy_grid"});
  testing::expect_error([&] { set_avatar_option(set, "steps=1.5"); }, {"steps: must be a whole number, got 1.5"});
  testing::expect_error([&] { set_avatar_option(set, "optimizer.type=sgd"); },
                        {"optimizer.type: must be \"adam\"", "sgd"});
  testing::expect_error([&] { set_avatar_option(set, "seed=-1"); }, {"seed: must be >= 0"});
  testing::expect_error([&] { set_avatar_option(set, "steps"); }, {"expected key=value"});
}

}  // namespace
}  // namespace fskin
