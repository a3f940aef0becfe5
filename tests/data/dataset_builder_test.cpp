#include "fskin/data/dataset_builder.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstdlib>
#include <filesystem>
#include <set>

#include <nlohmann/json.hpp>

#include "data/analytic_meshes.h"
#include "fskin/data/dataset.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/lowpoly_character.h"
#include "fskin/data/thin_parts.h"
#include "fskin/geometry/character_size.h"
#include "fskin/data/pose_generators.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/util/atomic_file.h"
#include "fskin/version.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// A capsule "body" 0.8 m tall with three joints at its centre named like
// SMPL's pelvis and hips (so the Da-pose exists): the top half follows the
// pelvis, the bottom half the hips (left for x > 0, right otherwise).
BodyModel capsule_model() {
  const auto mesh = testing::capsule_mesh(0.1, 0.3, 16, 32);
  const int64_t V = mesh.num_vertices();
  BodyModelData data;
  data.v_template = mesh.vertices;
  data.faces = mesh.faces;
  auto weights = torch::zeros({V, 3});
  const auto y = mesh.vertices.select(1, 1), x = mesh.vertices.select(1, 0);
  weights.select(1, 0).copy_((y >= 0).to(torch::kFloat32));
  weights.select(1, 1).copy_(((y < 0) & (x > 0)).to(torch::kFloat32));
  weights.select(1, 2).copy_(((y < 0) & (x <= 0)).to(torch::kFloat32));
  data.weights = weights;
  data.J_regressor = torch::full({3, V}, 1.0 / static_cast<double>(V));
  data.parents = {-1, 0, 0};
  data.joint_names = {"pelvis", "left_hip", "right_hip"};
  return BodyModel(data, "capsule model");
}

struct Fixture {
  BodyModel model = capsule_model();
  // Not SMPL's skeleton (three joints): motions inside given ranges.
  JointRanges ranges = JointRanges(3, JointRange{{-0.3, -0.3, -0.3}, {0.3, 0.3, 0.3}});
  PoseSet poses = make_training_poses(model.data().joint_names, ranges, {2, 5, 1});
  PoseSet ood = make_ood_poses(model.data().joint_names, ranges, {3, 2});
  DatasetBuildOptions options(const fs::path& dir, uint64_t seed = 0) const {
    DatasetBuildOptions o;
    o.out_dir = dir.string();
    o.model_source = "capsule";
    o.poses_source = "train poses";
    o.ood_poses_source = "ood poses";
    o.sampling.uniform_points = 600;
    o.sampling.surface_points = 900;
    o.seed = seed;
    o.progress = false;
    return o;
  }
};

std::vector<std::string> files_of(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

class DatasetBuilder : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  }
  Fixture f;
};

TEST_F(DatasetBuilder, WritesFramesAndManifestWithDisjointSplits) {
  const auto dir = testing::temp_dir("dataset_splits");
  const auto summary = build_dataset(f.model, f.poses, f.ood, f.options(dir));
  EXPECT_EQ(summary.frames_written, 13);
  EXPECT_EQ(summary.train, 8);
  EXPECT_EQ(summary.val, 1);
  EXPECT_EQ(summary.test_within, 1);
  EXPECT_EQ(summary.test_ood, 3);
  const auto manifest = nlohmann::json::parse(read_file((dir / "manifest.json").string()));
  EXPECT_TRUE(manifest["complete"].get<bool>());
  EXPECT_EQ(manifest["fskin_version"], FSKIN_VERSION);
  EXPECT_EQ(manifest["canonical_pose"], "rest");  // the default for a skeleton that is not SMPL's
  EXPECT_EQ(manifest["sampling"]["uniform_points"], 600);
  std::set<std::string> all;
  size_t total = 0;
  for (const auto& split : dataset_split_names()) {
    for (const auto& file : manifest["splits"][split]) {
      all.insert(file.get<std::string>());
      EXPECT_TRUE(fs::exists(dir / file.get<std::string>()));
    }
    total += manifest["splits"][split].size();
  }
  EXPECT_EQ(all.size(), total);  // no frame in two splits
  EXPECT_EQ(total, 13u);
  // Noise scaled to the 0.8 m body.
  EXPECT_NEAR(manifest["sampling"]["noise_sigma"].get<double>(), 0.01 * 0.8 / 1.7, 1e-4);

  const auto frame = DatasetFrame::load((dir / "train_00003.npz").string());
  EXPECT_EQ(frame.num_points(), 1500);
  EXPECT_EQ(frame.num_uniform, 600);
  EXPECT_TRUE(torch::allclose(frame.pose, f.poses.poses[3]));
  // canonical -> posed = (rest -> posed) (rest -> canonical)^-1.
  const auto canonical = DatasetFrame::load((dir / "canonical.npz").string());
  EXPECT_TRUE(torch::allclose(frame.bone_transforms.matmul(canonical.bone_transforms_rest),
                              frame.bone_transforms_rest, 1e-5, 1e-5));
  // The skeleton travels with the data: parents and the canonical joints (the
  // rest joints moved by their own rest -> canonical transform).
  EXPECT_EQ(manifest["parents"].get<std::vector<int64_t>>(), f.model.data().parents);
  const auto rest_joints = f.model.skeleton().rest_joints;
  const auto moved = transform_points(canonical.bone_transforms_rest, rest_joints);
  ASSERT_TRUE(canonical.joints.defined());
  EXPECT_TRUE(torch::allclose(canonical.joints, moved, 1e-5, 1e-5));
  // About half of the near-surface points are inside; fewer of the box points.
  const double surface = frame.surface_occupancy().to(torch::kFloat64).mean().item<double>();
  EXPECT_NEAR(surface, 0.5, 0.1);
  EXPECT_LT(frame.uniform_occupancy().to(torch::kFloat64).mean().item<double>(), 0.4);
  fs::remove_all(dir);
}

TEST_F(DatasetBuilder, RestPoseFramesMatchTheAnalyticCapsule) {
  const auto dir = testing::temp_dir("dataset_rest");
  PoseSet rest = f.poses;
  rest.poses = torch::zeros_like(rest.poses);
  auto options = f.options(dir);
  options.canonical_pose = "rest";
  build_dataset(f.model, rest, PoseSet{}, options);
  const auto frame = DatasetFrame::load((dir / "train_00000.npz").string());
  EXPECT_TRUE(torch::allclose(frame.bone_transforms, torch::eye(4).expand({3, 4, 4})));
  // Capsule radius 0.1 around y in [-0.3, 0.3] (polygonal: 16 x 32 facets).
  const auto p = frame.points;
  auto axis = torch::zeros_like(p);
  axis.select(1, 1).copy_(p.select(1, 1).clamp(-0.3, 0.3));
  const auto d = (p - axis).norm(2, 1) - 0.1;
  const auto away = d.abs() > 0.006;
  EXPECT_TRUE(torch::equal(frame.occupancy.to(torch::kBool).index({away}), (d < 0).index({away})));
  fs::remove_all(dir);
}

// Thin-part oversampling reaches the training frames only: the test frames'
// points define IoU_surf and stay area-uniform.
TEST_F(DatasetBuilder, ThinSurfaceShareOversamplesThinPartsInTrainingFramesOnly) {
  const auto dir = testing::temp_dir("dataset_thin");
  LowPolyOptions fox;
  fox.kind = LowPolyKind::Animal;
  const auto model = make_lowpoly_model(fox);
  PoseSet rest;
  rest.poses = torch::zeros({10, model.num_joints(), 3});
  rest.trans = torch::zeros({10, 3});
  auto options = f.options(dir);
  options.sampling.uniform_points = 0;
  options.sampling.surface_points = 4000;
  options.canonical_pose = "rest";
  options.thin_surface_share = 0.6;
  build_dataset(model, rest, PoseSet{}, options);
  const auto manifest = nlohmann::json::parse(read_file((dir / "manifest.json").string()));
  EXPECT_EQ(manifest["sampling"]["thin_surface_share"].get<double>(), 0.6);
  const int64_t thin_count = manifest["sampling"]["thin_faces"].get<int64_t>();
  const auto mesh = model.template_mesh();
  const auto thin = thin_faces(mesh, character_size(mesh.vertices) / 32);
  EXPECT_EQ(thin_count, thin.size(0));
  ASSERT_GT(thin.size(0), 0);
  ASSERT_LT(thin.size(0), mesh.num_faces() / 2);
  // Share of a frame's points nearest to a vertex of a thin face.
  auto on_thin_vertex = torch::zeros({mesh.num_vertices()}, torch::kBool);
  on_thin_vertex.index_put_({mesh.faces.index_select(0, thin).flatten()}, true);
  const auto share = [&](const std::string& file) {
    const auto frame = DatasetFrame::load((dir / file).string());
    const auto nearest = torch::cdist(frame.points, mesh.vertices.to(torch::kFloat32)).argmin(1);
    return on_thin_vertex.index_select(0, nearest).to(torch::kFloat64).mean().item<double>();
  };
  const double train = share("train_00000.npz"), test = share("test_within_00000.npz");
  EXPECT_GT(train, test + 0.3) << "train " << train << ", test " << test;
  EXPECT_GT(train, 0.45);  // 0.6 on thin faces; low-poly faces reach past their nearest vertices
  fs::remove_all(dir);
  auto bad = f.options(dir);
  bad.thin_surface_share = 1.5;
  testing::expect_error([&] { build_dataset(f.model, f.poses, f.ood, bad); }, {"thin-surface share"});
}

TEST_F(DatasetBuilder, SameSeedGivesIdenticalBytesAndResumeRewritesOnlyWhatIsMissing) {
  const auto a = testing::temp_dir("dataset_a"), b = testing::temp_dir("dataset_b");
  build_dataset(f.model, f.poses, f.ood, f.options(a, 3));
  build_dataset(f.model, f.poses, f.ood, f.options(b, 3));
  const auto names = files_of(a);
  ASSERT_EQ(names, files_of(b));
  for (const auto& name : names)
    EXPECT_EQ(read_file((a / name).string()), read_file((b / name).string())) << name;

  // Interrupted build: a frame is missing and the manifest says incomplete.
  const std::string removed = "test_ood_00001.npz";
  fs::remove(b / removed);
  auto manifest = nlohmann::json::parse(read_file((b / "manifest.json").string()));
  manifest["complete"] = false;
  write_file_atomically((b / "manifest.json").string(), manifest.dump(2) + "\n");
  testing::expect_error([&] { Dataset::load(b.string(), "train"); }, {"did not finish"});
  const auto summary = build_dataset(f.model, f.poses, f.ood, f.options(b, 3));
  EXPECT_EQ(summary.frames_written, 1);
  EXPECT_EQ(summary.frames_skipped, 12);
  for (const auto& name : names)
    EXPECT_EQ(read_file((a / name).string()), read_file((b / name).string())) << name;

  // Other parameters into the same directory are refused; another seed differs.
  testing::expect_error([&] { build_dataset(f.model, f.poses, f.ood, f.options(b, 4)); },
                        {"different inputs or parameters"});
  const auto c = testing::temp_dir("dataset_c");
  build_dataset(f.model, f.poses, f.ood, f.options(c, 4));
  EXPECT_NE(read_file((a / "train_00000.npz").string()), read_file((c / "train_00000.npz").string()));
  for (const auto& dir : {a, b, c}) fs::remove_all(dir);
}

TEST_F(DatasetBuilder, DatasetServesDeterministicBatches) {
  const auto dir = testing::temp_dir("dataset_batches");
  build_dataset(f.model, f.poses, f.ood, f.options(dir));
  const auto train = Dataset::load(dir.string(), "train");
  EXPECT_EQ(train.size(), 8);
  EXPECT_EQ(Dataset::load(dir.string(), "test_ood").size(), 3);
  EXPECT_EQ(train.joint_names(), f.model.data().joint_names);
  Rng r1(5), r2(5);
  const auto batch = train.sample_batch(4, 200, 25, r1);
  ASSERT_EQ(batch.points.sizes(), (std::vector<int64_t>{4, 225, 3}));
  ASSERT_EQ(batch.occupancy.sizes(), (std::vector<int64_t>{4, 225}));
  ASSERT_EQ(batch.bone_transforms.sizes(), (std::vector<int64_t>{4, 3, 4, 4}));
  EXPECT_EQ(std::set<int64_t>(batch.frames.begin(), batch.frames.end()).size(), 4u);
  const auto again = train.sample_batch(4, 200, 25, r2);
  EXPECT_TRUE(torch::equal(batch.points, again.points));
  EXPECT_EQ(batch.frames, again.frames);
  // Every batch point is a point of its frame, from the right half (distances
  // by direct differences, cdist compute_mode 2: exactly 0 for equal points
  // whatever the BLAS kernel).
  for (int b = 0; b < 4; ++b) {
    const auto& frame = train.frame(batch.frames[b]);
    const auto surface = batch.points[b].slice(0, 0, 200), uniform = batch.points[b].slice(0, 200);
    EXPECT_TRUE(torch::cdist(surface, frame.surface_points(), 2.0, 2).amin(1).max().item<float>() == 0.0f);
    EXPECT_TRUE(torch::cdist(uniform, frame.uniform_points(), 2.0, 2).amin(1).max().item<float>() == 0.0f);
    EXPECT_TRUE(torch::equal(batch.bone_transforms[b], frame.bone_transforms));
  }
  EXPECT_TRUE(((batch.occupancy == 0) | (batch.occupancy == 1)).all().item<bool>());
  testing::expect_error([&] { Dataset::load(dir.string(), "holdout"); }, {"unknown split"});
  fs::remove_all(dir);
}

TEST_F(DatasetBuilder, CommandLineBuildsADataset) {
  const auto dir = testing::temp_dir("dataset_cli");
  f.model.save((dir / "model.npz").string());
  const std::string cli = FSKIN_CLI_PATH;
  const auto run = [&](const std::string& args) {
    return std::system((cli + " " + args + " > " + (dir / "log.txt").string() + " 2>&1").c_str());
  };
  const std::string model = (dir / "model.npz").string();
  // A skeleton fskin has no motions for: it says so, and takes ranges from a clip.
  EXPECT_NE(run("poses train --model " + model + " --out " + (dir / "p.npz").string()), 0);
  EXPECT_NE(read_file((dir / "log.txt").string()).find("--ranges-from"), std::string::npos);
  const std::string clip = (dir / "clip.npz").string();
  f.poses.save(clip);
  ASSERT_EQ(run("poses train --model " + model + " --ranges-from " + clip + " --out " + (dir / "p.npz").string() +
                " --sequences 2 --frames 3"),
            0)
      << read_file((dir / "log.txt").string());
  ASSERT_EQ(run("poses ood --model " + model + " --ranges-from " + clip + " --out " + (dir / "q.npz").string() +
                " --count 2"),
            0)
      << read_file((dir / "log.txt").string());
  EXPECT_NE(read_file((dir / "log.txt").string()).find("beyond the training ranges"), std::string::npos);
  ASSERT_EQ(run("--threads 2 data build --model " + model + " --poses " + (dir / "p.npz").string() +
                " --ood-poses " + (dir / "q.npz").string() + " --out " + (dir / "set").string() +
                " --points 1000 --seed 4 --quiet"),
            0)
      << read_file((dir / "log.txt").string());
  EXPECT_NE(read_file((dir / "log.txt").string()).find("8 frames written"), std::string::npos);
  EXPECT_EQ(Dataset::load((dir / "set").string(), "test_ood").size(), 2);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fskin

namespace fskin {
namespace {

TEST(CanonicalPose, DefaultIsTheModelsDeclaredPoseElseDaForSmplElseRest) {
  const auto capsule = capsule_model();
  EXPECT_EQ(resolve_canonical_pose(capsule, "default"), "rest");
  EXPECT_EQ(canonical_pose(capsule, "default").abs().max().item<float>(), 0.0f);
  EXPECT_EQ(resolve_canonical_pose(capsule, "da"), "da");  // asked for: it has the hips
  // A model file that declares its canonical pose gets it, through save and load.
  auto data = capsule.data();
  data.canonical_pose = torch::zeros({3, 3});
  data.canonical_pose[1][0] = 0.4;
  const auto dir = testing::temp_dir("canonical_pose");
  BodyModel(data, "declared").save((dir / "m.npz").string());
  const auto declared = BodyModel::load((dir / "m.npz").string());
  EXPECT_EQ(resolve_canonical_pose(declared, "default"), "model");
  EXPECT_FLOAT_EQ(canonical_pose(declared, "default")[1][0].item<float>(), 0.4f);
  data.canonical_pose = torch::zeros({2, 3});
  testing::expect_error([&] { BodyModel(data, "bad.npz"); }, {"bad.npz", "canonical_pose"});
  // The Da-pose of a skeleton without hips names what is missing.
  data.canonical_pose = torch::Tensor();
  data.joint_names = {"root", "a", "b"};
  testing::expect_error([&] { canonical_pose(BodyModel(data, "x"), "da"); }, {"left_hip", "rest"});
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fskin
