// `fskin mesh` and `fskin animate RUN --poses`, run as a user would, on a run
// trained for two steps on a tiny dataset of the built-in character.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstdlib>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "fskin/body/body_model.h"
#include "fskin/core/device.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/data/inside_test.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/import/gltf_import.h"
#include "fskin/inference/trained_run.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/data/pose_set.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/io/mesh_io.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

class MeshCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!inside_test_available()) return;
    dir_ = new fs::path(testing::temp_dir("cli_mesh"));
    const std::vector<std::string> steps = {
        "character --resolution 56 --out " + path("model.npz"),
        "poses train --model " + path("model.npz") + " --out " + path("poses.npz") + " --sequences 1 --frames 5",
        "data build --model " + path("model.npz") + " --poses " + path("poses.npz") + " --out " + path("set") +
            " --points 1000 --quiet",
        "train --data " + path("set") + " --out " + path("run") +
            " --steps 2 --quiet --set frames_per_batch=1 --set surface_points=100 --set uniform_points=50"
            " --set occupancy_hidden_dim=16 --set skinning_hidden_dim=16 --set grid_resolution=16"
            " --set skinning_prior_steps=0 --set encoding_frequencies=0",
    };
    // A failure here must fail every test (gtest would only skip them).
    setup_error_ = new std::string;
    for (const auto& step : steps) {
      if (run_cli(step) != 0) {
        *setup_error_ = step + "\n" + log();
        return;
      }
    }
  }
  static void TearDownTestSuite() {
    if (dir_) fs::remove_all(*dir_);
    delete dir_;
    dir_ = nullptr;
    delete setup_error_;
    setup_error_ = nullptr;
  }
  void SetUp() override {
    if (!inside_test_available()) GTEST_SKIP() << "built without Embree (no dataset)";
    ASSERT_TRUE(setup_error_ != nullptr && setup_error_->empty()) << "fixture setup failed: "
                                                                  << (setup_error_ ? *setup_error_ : "");
  }

  static std::string path(const std::string& name) { return (*dir_ / name).string(); }
  static int run_cli(const std::string& arguments) {
    return std::system((std::string(FSKIN_CLI_PATH) + " " + arguments + " > " + path("log.txt") + " 2>&1").c_str());
  }
  static std::string log() { return read_file(path("log.txt")); }
  // Fails the test unless the command fails with a message containing `part`.
  static void expect_failure(const std::string& arguments, const std::string& part) {
    EXPECT_NE(run_cli(arguments), 0) << arguments;
    EXPECT_NE(log().find(part), std::string::npos) << arguments << "\n" << log();
  }

  static fs::path* dir_;
  static std::string* setup_error_;
};
fs::path* MeshCommand::dir_ = nullptr;
std::string* MeshCommand::setup_error_ = nullptr;

TEST_F(MeshCommand, WritesPosedAndCanonicalMeshes) {
  const std::string grid = " --resolution 32 --initial 8 --quiet";
  ASSERT_EQ(run_cli("mesh " + path("run") + " --pose " + path("poses.npz") + " --index 3 --out " + path("posed.ply") +
                    grid),
            0)
      << log();
  EXPECT_NE(log().find("samples evaluated"), std::string::npos) << log();
  const auto posed = io::read_mesh(path("posed.ply"));
  EXPECT_GT(posed.num_faces(), 0);
  ASSERT_EQ(run_cli("mesh " + path("run") + " --canonical --largest-component --out " + path("canonical.obj") + grid),
            0)
      << log();
  const auto canonical = io::read_mesh(path("canonical.obj"));
  ASSERT_GT(canonical.num_faces(), 0);
  EXPECT_EQ(connected_components(canonical).count, 1);
}

TEST(MeshCommandArguments, AreCheckedBeforeAnyWork) {
  const auto dir = testing::temp_dir("cli_mesh_arguments");
  const auto path = [&](const std::string& name) { return (dir / name).string(); };
  PoseSet{torch::zeros({5, 24, 3}), torch::zeros({5, 3}), {}}.save(path("poses.npz"));
  const auto expect_failure = [&](const std::string& arguments, const std::string& part) {
    EXPECT_NE(std::system((std::string(FSKIN_CLI_PATH) + " " + arguments + " > " + path("log.txt") + " 2>&1").c_str()),
              0)
        << arguments;
    const auto log = read_file(path("log.txt"));
    EXPECT_NE(log.find(part), std::string::npos) << arguments << "\n" << log;
  };
  const std::string pose = " --pose " + path("poses.npz"), out = " --out " + path("x.ply");
  expect_failure("mesh " + path("no_such_run") + pose + out, "does not exist");
  expect_failure("mesh " + dir.string() + pose + out, "no config.json");
  expect_failure("mesh " + path("run") + pose + " --index 5" + out, "out of range [0, 5)");
  expect_failure("mesh " + path("run") + pose + " --resolution 48 --initial 32" + out, "power of two");
  expect_failure("mesh " + path("run") + pose + " --out " + path("x.stl"), ".ply or .obj");
  expect_failure("mesh " + path("run") + out, "--canonical");
  EXPECT_FALSE(fs::exists(path("x.ply")));
  fs::remove_all(dir);
}

TEST_F(MeshCommand, AnimateWritesOneMeshPerPose) {
  ASSERT_EQ(run_cli("animate " + path("run") + " --poses " + path("poses.npz") + " --out " + path("frames") +
                    " --resolution 16 --initial 8 --quiet"),
            0)
      << log();
  EXPECT_NE(log().find("s per pose"), std::string::npos) << log();
  for (int i = 0; i < 5; ++i) {
    const auto file = path("frames") + "/frame_000" + std::to_string(i) + ".ply";
    EXPECT_NO_THROW(io::read_mesh(file)) << file;
  }
  EXPECT_FALSE(fs::exists(path("frames") + "/frame_0005.ply"));
  const auto summary = nlohmann::json::parse(read_file(path("frames") + "/meshing.json"));
  EXPECT_EQ(summary.at("frames").size(), 5u);
  EXPECT_GT(summary.at("seconds_per_pose").get<double>(), 0.0);
  EXPECT_EQ(summary.at("resolution").get<int64_t>(), 16);
  expect_failure("animate " + path("run") + " --out " + path("frames"), "--poses");
  // A pose file of another skeleton: the error names the file and the joints expected.
  PoseSet{torch::zeros({2, 3, 3}), torch::zeros({2, 3}), {}}.save(path("three.npz"));
  expect_failure("animate " + path("run") + " --poses " + path("three.npz") + " --out " + path("other"), "three.npz");
  EXPECT_NE(log().find("24"), std::string::npos) << log();
}

// The rigged avatar plays back, in any glTF player, as the learned skinning of
// its canonical mesh with the four largest weights per vertex.
TEST_F(MeshCommand, ExportWritesARiggedAvatarThatPosesLikeTheLearnedSkinning) {
  const auto glb = path("avatar.glb");
  ASSERT_EQ(run_cli("export " + path("run") + " --out " + glb + " --clip " + path("poses.npz") +
                    " --resolution 32 --initial 8"),
            0)
      << log();
  EXPECT_NE(log().find("4 influences per vertex, 5 poses"), std::string::npos) << log();
  // Two training steps leave the canonical surface open at the box: keep it.
  const auto imported = import_gltf(glb, {/*keep_open_parts=*/true});
  ASSERT_EQ(imported.clips.size(), 1u);
  const BodyModel avatar(imported.model, glb);
  EXPECT_EQ(avatar.num_joints(), 24);
  const auto run = TrainedRun::load(path("run"));
  EXPECT_LT((imported.model.rest_joints - run.skeleton.joints).abs().max().item<float>(), 1e-5);
  const auto& clip = imported.clips[0].poses;
  const auto played = avatar.pose(clip.poses, {}, clip.trans).vertices;  // [5, V, 3]
  torch::NoGradGuard no_grad;
  const auto vertices = imported.model.v_template;
  run.model->train(false);
  run.model->freeze_for_inference();
  const auto [ids, values] = top_influences(run.model->deformer_skinning_field()->weights(vertices));
  const auto top4 = torch::zeros({vertices.size(0), avatar.num_joints()}).scatter_add(1, ids, values);
  const auto bones = DatasetPosing::load(run.data_dir).bone_transforms(PoseSet::load(path("poses.npz")), "poses");
  const auto expected = linear_blend_skinning(vertices.unsqueeze(0).expand({5, -1, -1}), top4, bones);
  const double height = (std::get<0>(vertices.max(0)) - std::get<0>(vertices.min(0))).max().item<double>();
  EXPECT_LT((played - expected).abs().max().item<double>(), 1e-4 * height);
  expect_failure("export " + path("run") + " --out " + path("avatar.fbx"), ".glb");
}

// With every influence (--influences 0) the rigged avatar plays back exactly
// as `fskin animate --repose` re-poses the same canonical mesh.
TEST_F(MeshCommand, ExportWithEveryInfluenceEqualsAnimateRepose) {
  const std::string meshing = " --resolution 32 --initial 8 --largest-component";
  ASSERT_EQ(run_cli("export " + path("run") + " --out " + path("exact.glb") + " --clip " + path("poses.npz") +
                    " --influences 0" + meshing),
            0)
      << log();
  EXPECT_NE(log().find("24 influences per vertex"), std::string::npos) << log();
  ASSERT_EQ(run_cli("animate " + path("run") + " --poses " + path("poses.npz") + " --repose --quiet --out " +
                    path("reposed") + meshing),
            0)
      << log();
  const auto imported = import_gltf(path("exact.glb"), {/*keep_open_parts=*/true});
  const BodyModel avatar(imported.model, "exact.glb");
  const auto& clip = imported.clips.at(0).poses;
  const auto played = avatar.pose(clip.poses, {}, clip.trans).vertices;  // [5, V, 3]
  const auto canonical = io::read_mesh(path("reposed") + "/canonical.ply");
  ASSERT_EQ(canonical.num_vertices(), avatar.num_vertices());
  // The import welds and compacts: match its vertices to the canonical mesh's.
  const auto [distance, original] =
      torch::cdist(imported.model.v_template.to(torch::kFloat64), canonical.vertices.to(torch::kFloat64)).min(1);
  ASSERT_LT(distance.max().item<double>(), 1e-6);
  const auto height = (std::get<0>(canonical.vertices.max(0)) - std::get<0>(canonical.vertices.min(0))).max();
  double largest = 0;
  for (int k = 0; k < 5; ++k) {
    const auto frame = io::read_mesh(path("reposed") + fmt::format("/frame_{:04d}.ply", k));
    largest = std::max(largest, (played[k] - frame.vertices.index_select(0, original)).abs().max().item<double>());
  }
  EXPECT_LT(largest, 1e-4 * height.item<double>());
}

// --device on every command that runs a model: a GPU where one is usable (the
// same IoU as on the CPU), otherwise an error naming the flag before any work.
TEST_F(MeshCommand, DeviceFlagRunsOnTheGpuOrFailsBeforeAnyWork) {
  const std::string eval = "eval " + path("run") + " --split train --max-frames 2 --quiet";
  ASSERT_EQ(run_cli(eval + " --device cpu"), 0) << log();
  const auto on_cpu = nlohmann::json::parse(read_file(path("run") + "/eval-train.json"));
  expect_failure(eval + " --device tpu", "--device tpu: expected cpu, cuda or cuda:N");
  expect_failure(eval + " --device cuda:x", "expected cpu, cuda or cuda:N");
  if (built_with_cuda() && torch::cuda::is_available()) {
    ASSERT_EQ(run_cli(eval + " --device cuda"), 0) << log();
    const auto on_gpu = nlohmann::json::parse(read_file(path("run") + "/eval-train.json"));
    EXPECT_NEAR(on_gpu.at("mean_iou_surf").get<double>(), on_cpu.at("mean_iou_surf").get<double>(), 2e-3);
    ASSERT_EQ(run_cli("mesh " + path("run") + " --canonical --device cuda --resolution 16 --initial 8 --quiet --out " +
                      path("gpu.ply")),
              0)
        << log();
    EXPECT_GT(io::read_mesh(path("gpu.ply")).num_faces(), 0);
    return;
  }
  const std::string why = built_with_cuda() ? "no CUDA device is visible" : "built without CUDA kernels";
  expect_failure(eval + " --device cuda", why);
  expect_failure("mesh " + path("run") + " --canonical --device cuda --out " + path("gpu.ply"), why);
  expect_failure("animate " + path("run") + " --poses " + path("poses.npz") + " --device cuda --out " +
                     path("gpu_frames"),
                 why);
  expect_failure("train --data " + path("set") + " --out " + path("gpu_run") + " --steps 1 --device cuda", why);
  expect_failure("bench deform --device cuda --points 10", why);
  EXPECT_FALSE(fs::exists(path("gpu.ply")));
  EXPECT_FALSE(fs::exists(path("gpu_frames")));
  EXPECT_FALSE(fs::exists(path("gpu_run")));
}

}  // namespace
}  // namespace fskin
