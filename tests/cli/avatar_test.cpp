// `fskin data images` and `fskin avatar train | eval | render | mesh`, run as a
// user would on a tiny image dataset of the built-in character.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "fskin/export/image.h"
#include "fskin/engine/run_lock.h"
#include "fskin/io/npz.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

class AvatarCommands : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(testing::temp_dir("cli_avatar"));
    setup_error_ = new std::string;
    const std::vector<std::string> steps = {
        "character --resolution 40 --out " + path("model.npz"),
        "poses train --model " + path("model.npz") + " --out " + path("poses.npz") + " --sequences 1 --frames 2",
        "poses ood --model " + path("model.npz") + " --out " + path("held_out.npz") + " --count 1",
        "data images --model " + path("model.npz") + " --poses " + path("poses.npz") + " --held-out-poses " +
            path("held_out.npz") + " --out " + path("images") +
            " --size 32 --views 2 --held-out-views 1 --novel-view-frames 1 --supersampling 1 --quiet",
        "avatar train --data " + path("images") + " --out " + path("run") +
            " --steps 20 --rays 256 --levels 4 --log2-table-size 12 --quiet",
    };
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
    ASSERT_TRUE(setup_error_ && setup_error_->empty()) << "fixture setup failed: " << *setup_error_;
  }
  static std::string path(const std::string& name) { return (*dir_ / name).string(); }
  static int run_cli(const std::string& arguments) {
    return std::system((std::string(FSKIN_CLI_PATH) + " " + arguments + " > " + path("log.txt") + " 2>&1").c_str());
  }
  static std::string log() { return read_file(path("log.txt")); }
  static fs::path* dir_;
  static std::string* setup_error_;
};
fs::path* AvatarCommands::dir_ = nullptr;
std::string* AvatarCommands::setup_error_ = nullptr;

TEST_F(AvatarCommands, EvalWritesPsnrPerSplit) {
  ASSERT_EQ(run_cli("avatar eval " + path("run") + " --split novel_pose --quiet"), 0) << log();
  EXPECT_NE(log().find("PSNR"), std::string::npos) << log();
  const auto json = nlohmann::json::parse(read_file(path("run/eval_novel_pose.json")));
  EXPECT_EQ(json.at("split"), "novel_pose");
  EXPECT_EQ(json.at("images"), 1);
  EXPECT_GT(json.at("mean_psnr").get<double>(), 5.0);
}

TEST_F(AvatarCommands, NoisyPosesAreRefinedReportedAndFitted) {
  ASSERT_EQ(run_cli("data perturb-poses --data " + path("images") + " --out " + path("noisy") + " --degrees 4"), 0)
      << log();
  EXPECT_NE(log().find("2 poses perturbed: "), std::string::npos) << log();
  EXPECT_NE(run_cli("data perturb-poses --data " + path("images") + " --out " + path("noisy")), 0);
  EXPECT_NE(log().find("not empty"), std::string::npos) << log();
  ASSERT_EQ(run_cli("avatar train --data " + path("noisy") + " --out " + path("refined") +
                    " --steps 4 --rays 128 --levels 4 --log2-table-size 12 --refine-poses --shading lambert"
                    " --appearance-codes 4 --learn-skinning --quiet"),
            0)
      << log();
  const auto recorded = nlohmann::json::parse(read_file(path("refined/avatar.json")));
  EXPECT_EQ(recorded.at("pose_refinement").at("enabled"), true);
  EXPECT_EQ(recorded.at("model").at("field").at("shading"), "lambert");
  EXPECT_EQ(recorded.at("model").at("field").at("appearance").at("dim"), 4);
  EXPECT_EQ(recorded.at("model").at("skinning").at("type"), "learned");
  ASSERT_EQ(run_cli("avatar poses " + path("refined") + " --out " + path("refined.npz")), 0) << log();
  EXPECT_NE(log().find("against the exact poses: given "), std::string::npos) << log();
  EXPECT_TRUE(io::NpzReader(path("refined.npz")).contains("bone_transforms_exact"));
  EXPECT_NE(run_cli("avatar poses " + path("run")), 0);
  EXPECT_NE(log().find("does not refine poses"), std::string::npos) << log();
  ASSERT_EQ(run_cli("avatar eval " + path("refined") + " --split novel_pose --fit-poses 2 --quiet"), 0) << log();
  EXPECT_EQ(nlohmann::json::parse(read_file(path("refined/eval_novel_pose.json"))).at("pose_fitting_steps"), 2);
  // Training poses' images with their frames' codes, other poses with the mean.
  ASSERT_EQ(run_cli("avatar render " + path("refined") + " --split train --index 0 --compare --out " +
                    path("coded.png")),
            0)
      << log();
  EXPECT_TRUE(fs::exists(path("coded.png")));
}

TEST_F(AvatarCommands, ALightShadesTheImages) {
  ASSERT_EQ(run_cli("data images --model " + path("model.npz") + " --poses " + path("poses.npz") + " --out " +
                    path("lit") + " --size 16 --views 1 --held-out-views 1 --novel-view-frames 0 --supersampling 1 "
                    "--light 0,1,0 --ambient 0.4 --quiet"),
            0)
      << log();
  const auto manifest = nlohmann::json::parse(read_file(path("lit/manifest.json")));
  EXPECT_EQ(manifest.at("light"), nlohmann::json({0.0, 1.0, 0.0}));
  EXPECT_NE(run_cli("data images --model " + path("model.npz") + " --poses " + path("poses.npz") + " --out " +
                    path("lit2") + " --light 0,1"),
            0);
}

TEST_F(AvatarCommands, RenderComparesWithTheGroundTruth) {
  ASSERT_EQ(run_cli("avatar render " + path("run") + " --split train --index 0,3 --compare --out " + path("cmp.png")),
            0)
      << log();
  const Image sheet = read_png(path("cmp.png"));
  EXPECT_EQ(sheet.width, 64);
  EXPECT_EQ(sheet.height, 64);
  ASSERT_EQ(run_cli("avatar render " + path("run") + " --turntable 3 --out " + path("turn")), 0) << log();
  EXPECT_TRUE(fs::exists(path("turn/frame_0002.png")));
  // A pose of a pose file, posed with the dataset's model, seen by a camera of a cameras.npz.
  ASSERT_EQ(run_cli("avatar render " + path("run") + " --poses " + path("held_out.npz") + " --pose-index 0 --cameras " +
                    path("images/novel_pose/cameras.npz") + " --out " + path("posed.png")),
            0)
      << log();
  EXPECT_EQ(read_png(path("posed.png")).width, 32);
  ASSERT_NE(run_cli("avatar render " + path("run") + " --poses " + path("held_out.npz") + " --pose-index 5 --out " +
                    path("x.png")),
            0);
  EXPECT_NE(log().find("--pose-index 5 is out of range"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar render " + path("run") + " --split train --index 9 --out " + path("x.png")), 0);
  EXPECT_NE(log().find("--index 9 is out of range"), std::string::npos) << log();
}

// Any rig, no body model: bone transforms (canonical -> posed) as a split's
// poses.npz holds them, one pose or an animation of every pose.
TEST_F(AvatarCommands, RenderTakesBoneTransformsAndAnimations) {
  const std::string bones = path("images/train/poses.npz");
  ASSERT_EQ(run_cli("avatar render " + path("run") + " --split train --index 2 --out " + path("own.png")), 0) << log();
  ASSERT_EQ(run_cli("avatar render " + path("run") + " --split train --index 2 --bones " + bones +
                    " --pose-index 2 --out " + path("given.png")),
            0)
      << log();
  EXPECT_EQ(read_file(path("own.png")), read_file(path("given.png")));  // the same bones, the same camera
  ASSERT_EQ(run_cli("avatar render " + path("run") + " --split train --index 0 --bones " + bones + " --animation --out " +
                    path("animation")),
            0)
      << log();
  EXPECT_TRUE(fs::exists(path("animation/frame_0003.png")));  // 2 poses x 2 views in the train split
  EXPECT_FALSE(fs::exists(path("animation/frame_0004.png")));
  EXPECT_EQ(read_png(path("animation/frame_0002.png")).width, 32);
  // Wrong joint count, a missing array, no poses for --animation, both sources.
  io::NpzWriter wrong;
  wrong.add("bone_transforms", torch::eye(4).expand({1, 3, 4, 4}).contiguous());
  wrong.save(path("wrong_bones.npz"));
  ASSERT_NE(run_cli("avatar render " + path("run") + " --bones " + path("wrong_bones.npz") + " --out " + path("x.png")), 0);
  EXPECT_NE(log().find("wrong_bones.npz: bone_transforms"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar render " + path("run") + " --bones " + path("held_out.npz") + " --out " + path("x.png")), 0);
  EXPECT_NE(log().find("no bone_transforms array"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar render " + path("run") + " --animation --out " + path("anim2")), 0);
  EXPECT_NE(log().find("--animation renders the poses of --poses or --bones"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar render " + path("run") + " --bones " + bones + " --poses " + path("held_out.npz") +
                    " --out " + path("x.png")),
            0);
  EXPECT_NE(log().find("not both"), std::string::npos) << log();
}

// The same commands on an avatar of articulated Gaussians (docs/gaussian_avatars.md).
TEST_F(AvatarCommands, GaussianAvatarsTrainEvaluateAndRender) {
  const std::string run = path("gaussians");
  ASSERT_EQ(run_cli("avatar train --data " + path("images") + " --out " + run +
                    " --representation gaussians --steps 30 --quiet --set model.gaussians.initial=800 --set "
                    "density.start=10 --set density.every=10 --refine-poses --set pose_refinement.first_pass_steps=10 "
                    "--shading irradiance"),
            0)
      << log();
  EXPECT_NE(log().find("Gaussians; last loss"), std::string::npos) << log();
  EXPECT_NE(log().find("first pass of pose refinement: steps 0 -> 10"), std::string::npos) << log();
  const auto document = nlohmann::json::parse(read_file(run + "/gaussian_avatar.json"));
  EXPECT_EQ(document.at("model").at("type"), "gaussian-avatar");
  EXPECT_EQ(document.at("density").at("every"), 10);
  EXPECT_EQ(document.at("model").at("shading"), "irradiance");
  EXPECT_EQ(document.at("pose_refinement").at("enabled"), true);
  ASSERT_EQ(run_cli("config show " + run), 0) << log();
  EXPECT_NE(log().find("\"gaussian-avatar\""), std::string::npos) << log();
  ASSERT_EQ(run_cli("avatar eval " + run + " --split novel_pose --quiet"), 0) << log();
  const auto scores = nlohmann::json::parse(read_file(run + "/eval_novel_pose.json"));
  EXPECT_GT(scores.at("mean_psnr").get<double>(), 10.0);
  ASSERT_EQ(run_cli("avatar render " + run + " --split train --index 0,1 --compare --out " + path("gs.png")), 0)
      << log();
  EXPECT_EQ(read_png(path("gs.png")).width, 64);
  ASSERT_EQ(run_cli("avatar render " + run + " --turntable 2 --out " + path("gs_turn")), 0) << log();
  EXPECT_TRUE(fs::exists(path("gs_turn/frame_0001.png")));
  ASSERT_EQ(run_cli("avatar export " + run + " --split train --out " + path("gs.ply")), 0) << log();
  EXPECT_NE(log().find("an animation of 4 poses"), std::string::npos) << log();
  EXPECT_EQ(read_file(path("gs.ply")).rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  ASSERT_EQ(run_cli("avatar export " + run + " --split train --influences 0 --out " + path("gs.glb")), 0) << log();
  EXPECT_EQ(read_file(path("gs.glb")).rfind("glTF", 0), 0u);
  EXPECT_NE(read_file(path("gs.glb")).find("KHR_gaussian_splatting:SCALE"), std::string::npos);
  EXPECT_NE(log().find("learned lighting is not in the file"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar export " + run + " --out " + path("gs.obj")), 0);
  EXPECT_NE(log().find("gs.obj: a Gaussian avatar is written as a 3DGS .ply or a glTF"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar export " + run + " --influences 4 --out " + path("gs2.ply")), 0);
  EXPECT_NE(log().find("--influences applies to glTF"), std::string::npos) << log();
  // The Gaussians baked into the character's mesh: a skinned, vertex-coloured glTF, and its scores.
  ASSERT_EQ(run_cli("avatar export " + run + " --mesh --subdivisions 1 --split train --out " + path("baked.glb")), 0)
      << log();
  EXPECT_NE(log().find("vertices with colours baked from"), std::string::npos) << log();
  const auto baked = read_file(path("baked.glb"));
  EXPECT_EQ(baked.rfind("glTF", 0), 0u);
  EXPECT_NE(baked.find("COLOR_0"), std::string::npos);
  EXPECT_NE(baked.find("JOINTS_0"), std::string::npos);
  EXPECT_EQ(baked.find("KHR_gaussian_splatting"), std::string::npos);
  ASSERT_EQ(run_cli("avatar render " + run + " --mesh --split train --index 0 --compare --out " + path("baked.png")), 0)
      << log();
  EXPECT_EQ(read_png(path("baked.png")).width, 64);
  ASSERT_EQ(run_cli("avatar eval " + run + " --mesh --split novel_pose --quiet"), 0) << log();
  const auto mesh_scores = nlohmann::json::parse(read_file(run + "/eval_mesh_novel_pose.json"));
  EXPECT_GT(mesh_scores.at("mean_psnr").get<double>(), 10.0);
  ASSERT_NE(run_cli("avatar export " + run + " --mesh --out " + path("baked.ply")), 0);
  EXPECT_NE(log().find("baked.ply: the mesh is written as glTF"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar export " + run + " --subdivisions 2 --out " + path("gs3.glb")), 0);
  EXPECT_NE(log().find("--subdivisions applies with --mesh"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar eval " + run + " --mesh --fit-poses 2"), 0);
  EXPECT_NE(log().find("--fit-poses fits the Gaussians' poses"), std::string::npos) << log();
  // The volume avatar's options are not the Gaussian avatar's; a volume run is not continued as one.
  ASSERT_NE(run_cli("avatar train --data " + path("images") + " --out " + path("gs2") +
                    " --representation gaussians --rays 64"),
            0);
  EXPECT_NE(log().find("--rays is an option of the volume avatar"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar train --data " + path("images") + " --out " + path("run") +
                    " --representation gaussians --resume --steps 2"),
            0);
  EXPECT_NE(log().find("holds a volume avatar run"), std::string::npos) << log();
  // Its refined poses, and held-out poses fitted at test time.
  ASSERT_EQ(run_cli("avatar poses " + run + " --out " + path("gs_poses.npz")), 0) << log();
  EXPECT_NE(log().find("training frames; mean correction"), std::string::npos) << log();
  EXPECT_TRUE(fs::exists(path("gs_poses.npz")));
  ASSERT_EQ(run_cli("avatar eval " + run + " --fit-poses 3 --max-images 1 --quiet --json " + path("fit.json")), 0)
      << log();
  EXPECT_EQ(nlohmann::json::parse(read_file(path("fit.json"))).at("pose_fitting_steps"), 3);
  ASSERT_NE(run_cli("avatar train --data " + path("images") + " --out " + path("gs3") +
                    " --representation gaussians --shading lambert --steps 1"),
            0);
  EXPECT_NE(log().find("shading must be \"none\" or \"irradiance\""), std::string::npos) << log();
}

// The export itself is checked on a trained avatar (AvatarTraining in
// tests/radiance); the fixture's 20-step avatar has no surface yet.
TEST_F(AvatarCommands, ExportNamesWhatIsWrong) {
  ASSERT_NE(run_cli("avatar export " + path("run") + " --out " + path("avatar.fbx")), 0);
  EXPECT_NE(log().find("avatar.fbx: the avatar is written as glTF"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar export " + path("run") + " --split train --bones " + path("images/train/poses.npz") +
                    " --out " + path("a.glb")),
            0);
  EXPECT_NE(log().find("not both"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar export " + path("run") + " --split train --out " + path("a.glb")), 0);
  EXPECT_NE(log().find("is the avatar trained?"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar export " + path("run") + " --mesh --out " + path("a.glb")), 0);
  EXPECT_NE(log().find("a volume avatar's export is a mesh already"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar eval " + path("run") + " --mesh"), 0);
  EXPECT_NE(log().find("this is a volume avatar"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar render " + path("run") + " --mesh --out " + path("a.png")), 0);
  EXPECT_NE(log().find("draws a Gaussian avatar's baked mesh; this is a volume avatar"), std::string::npos) << log();
}

TEST_F(AvatarCommands, TrainingAgainNeedsResume) {
  ASSERT_NE(run_cli("avatar train --data " + path("images") + " --out " + path("run") + " --steps 30 --quiet"), 0);
  EXPECT_NE(log().find("--resume"), std::string::npos) << log();
  ASSERT_EQ(run_cli("avatar train --data " + path("images") + " --out " + path("run") + " --steps 25 --resume --quiet"),
            0)
      << log();
  EXPECT_NE(log().find("steps 20 -> 25"), std::string::npos) << log();
}

// One writer per run: while another process holds the run (here this test
// process, through the same lock file), `avatar train --resume` fails at once
// naming it; once free, the resume removes what a killed write left and logs
// each step once.
TEST_F(AvatarCommands, ASecondWriterFailsAndAResumeCleansUp) {
  const std::string run = path("run_busy");
  fs::remove_all(run);
  fs::copy(path("run"), run, fs::copy_options::recursive);
  {
    const RunLock holder(run);
    ASSERT_NE(run_cli("avatar train --data " + path("images") + " --out " + run + " --steps 24 --resume --quiet"), 0)
        << log();
    EXPECT_NE(log().find("PID " + std::to_string(::getpid())), std::string::npos) << log();
  }
  const auto log_steps = [&] {
    std::vector<int64_t> steps;
    std::istringstream lines(read_file((fs::path(run) / "log.jsonl").string()));
    for (std::string line; std::getline(lines, line);) steps.push_back(nlohmann::json::parse(line).at("step"));
    return steps;
  };
  const int64_t saved = log_steps().back();  // the run's checkpoint is at its last logged step
  // What a run killed after its checkpoint leaves: a temporary of the next
  // checkpoint and log lines past the saved step (the last one cut).
  const auto stale = fs::path(run) / "checkpoint-99999999.fskin.tmp-999999999";  // no such process
  std::ofstream(stale) << "half a checkpoint";
  std::ofstream(fs::path(run) / "log.jsonl", std::ios::app)
      << "{\"step\": " << saved + 1 << "}\n{\"step\": " << saved + 2 << ", \"lo";
  const int64_t target = saved + 3;
  ASSERT_EQ(run_cli("avatar train --data " + path("images") + " --out " + run + " --steps " + std::to_string(target) +
                    " --resume --quiet"),
            0)
      << log();
  EXPECT_FALSE(fs::exists(stale));
  const auto steps = log_steps();
  EXPECT_EQ(std::set<int64_t>(steps.begin(), steps.end()).size(), steps.size());
  EXPECT_EQ(std::count(steps.begin(), steps.end(), saved + 1), 0);
  EXPECT_EQ(steps.back(), target);
}

TEST_F(AvatarCommands, OutputsMayNotOverwriteTheDataOrPretendToBeJpeg) {
  ASSERT_NE(run_cli("avatar train --data " + path("images") + " --out " + path("images") + " --steps 1 --quiet"), 0)
      << log();
  EXPECT_NE(log().find("is the input"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar render " + path("run") + " --split train --index 0 --out " + path("x.jpg")), 0) << log();
  EXPECT_NE(log().find("name the file .png"), std::string::npos) << log();
  EXPECT_FALSE(fs::exists(path("x.jpg")));
}

TEST_F(AvatarCommands, ConfigFileAndSetReachTheOptionsAndConfigShowPrintsThem) {
  write_file_atomically(path("avatar_config.json"), R"({"model": {"rendering": {"samples_per_diagonal": 100}}})");
  const std::string train = "avatar train --data " + path("images") + " --steps 1 --rays 64 --levels 4 " +
                            "--log2-table-size 12 --quiet --config " + path("avatar_config.json");
  ASSERT_EQ(run_cli(train + " --out " + path("run_config") + " --set losses.opacity.weight=0.25"), 0) << log();
  ASSERT_EQ(run_cli("config show " + path("run_config")), 0) << log();
  const auto shown = nlohmann::json::parse(log());
  EXPECT_EQ(shown.at("model").at("rendering").at("samples_per_diagonal"), 100);
  EXPECT_EQ(shown.at("losses").at("opacity").at("weight"), 0.25);
  EXPECT_EQ(shown.at("model").at("field").at("encoding").at("levels"), 4);  // the flag
  ASSERT_NE(run_cli(train + " --out " + path("run_config2") + " --set losses.opacity.wieght=1"), 0);
  EXPECT_NE(log().find("losses.opacity.wieght: unknown key"), std::string::npos) << log();
  EXPECT_FALSE(fs::exists(path("run_config2")));
}

TEST_F(AvatarCommands, BadInputsAreNamed) {
  ASSERT_NE(run_cli("avatar train --data " + path("nothing") + " --out " + path("run2") + " --quiet"), 0);
  EXPECT_NE(log().find("manifest.json"), std::string::npos) << log();
  ASSERT_NE(run_cli("avatar eval " + path("images")), 0);
  EXPECT_NE(log().find("avatar.json"), std::string::npos) << log();
}

}  // namespace
}  // namespace fskin
