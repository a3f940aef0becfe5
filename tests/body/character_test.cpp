#include "fskin/body/character.h"

#include <ATen/Parallel.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <torch/torch.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "fskin/data/pose_set.h"
#include "fskin/geometry/mesh_topology.h"
#include "test_util.h"

namespace fskin {
namespace {

// Low resolutions keep the suite fast; the properties do not depend on it.
CharacterOptions low_resolution(uint64_t seed = 0, bool clothed = false) {
  CharacterOptions options;
  options.seed = seed;
  options.clothed = clothed;
  options.resolution = 56;
  return options;
}

const BodyModel& character() {
  static const BodyModel model = make_character_model(low_resolution());
  return model;
}

const BodyModel& clothed_character() {
  static const BodyModel model = make_character_model(low_resolution(0, true));
  return model;
}

int64_t joint(const std::string& name) { return character().skeleton().index_of(name); }

void expect_closed_genus_zero(const BodyModel& model) {
  const auto mesh = model.template_mesh();
  const auto topology = analyze_topology(mesh);
  EXPECT_TRUE(topology.is_closed_manifold());
  EXPECT_EQ(topology.boundary_edges, 0);
  EXPECT_EQ(topology.non_manifold_edges, 0);
  EXPECT_EQ(topology.euler_characteristic(), 2);
  EXPECT_EQ(topology.num_vertices, model.num_vertices());
  EXPECT_EQ(connected_components(mesh).count, 1);
  EXPECT_GT(signed_volume(mesh), 0.0);
}

TEST(Character, MeshIsOneClosedGenusZeroManifold) { expect_closed_genus_zero(character()); }

TEST(Character, ClothedVariantIsClosedTooAndHasMoreVolume) {
  expect_closed_genus_zero(clothed_character());
  EXPECT_GT(signed_volume(clothed_character().template_mesh()),
            signed_volume(character().template_mesh()) * 1.05);
}

TEST(Character, SmplJointTreeAndTPoseLayout) {
  const auto skeleton = character().skeleton();
  ASSERT_EQ(skeleton.num_joints(), 24);
  EXPECT_EQ(skeleton.parents, smpl_parents());
  EXPECT_EQ(skeleton.joint_names, smpl_joint_names());
  EXPECT_EQ(skeleton.joint_names[18], "left_elbow");
  const auto j = skeleton.rest_joints;
  const auto x = [&](const char* name) { return j[joint(name)][0].item<float>(); };
  const auto y = [&](const char* name) { return j[joint(name)][1].item<float>(); };
  // Left is +x, up is +y; arms horizontal, head on top.
  EXPECT_GT(x("left_wrist"), 0.5f);
  EXPECT_LT(x("right_wrist"), -0.5f);
  EXPECT_NEAR(y("left_wrist"), y("left_shoulder"), 0.03f);
  EXPECT_GT(y("head"), y("neck"));
  EXPECT_GT(y("pelvis"), y("left_knee"));
  EXPECT_GT(y("left_knee"), y("left_ankle"));
  // The body stands on y = 0 and is options.height tall.
  const auto v = character().data().v_template;
  EXPECT_NEAR(v.select(1, 1).min().item<float>(), 0.0f, 0.02f);
  EXPECT_NEAR(v.select(1, 1).max().item<float>(), 1.7f, 0.03f);
}

TEST(Character, DefaultResolutionGivesAboutTwentyThousandFaces) {
  const auto model = make_character_model(CharacterOptions{});
  EXPECT_GE(model.data().faces.size(0), 10000);
  EXPECT_LE(model.data().faces.size(0), 25000);
}

TEST(Character, WeightsAreConvexAndLocal) {
  const auto& w = character().data().weights;
  EXPECT_GE(w.min().item<float>(), 0.0f);
  EXPECT_LT((w.sum(1) - 1).abs().max().item<float>(), 1e-5f);
  // The hand tip follows the hand joint, the top of the head the head joint.
  const auto v = character().data().v_template;
  const int64_t tip = v.select(1, 0).argmax().item<int64_t>();
  const int64_t top = v.select(1, 1).argmax().item<int64_t>();
  EXPECT_GT(w[tip][joint("left_hand")].item<float>(), 0.9f);
  EXPECT_GT(w[top][joint("head")].item<float>(), 0.9f);
}

TEST(Character, JointRegressorIsConvexAndGivesTheRestJoints) {
  const auto& d = character().data();
  const auto& r = d.J_regressor;
  EXPECT_GE(r.min().item<float>(), 0.0f);
  EXPECT_LT((r.sum(1) - 1).abs().max().item<float>(), 1e-5f);
  EXPECT_TRUE(torch::allclose(torch::matmul(r, d.v_template), character().skeleton().rest_joints));
  // Rows use vertices around their joint only, and the regressed joints are
  // where the character was designed: the clothed variant has the same ones.
  const auto rest = character().skeleton().rest_joints;
  const auto distance = torch::cdist(rest, d.v_template);  // [J, V]
  EXPECT_LT(distance.index({r > 0}).max().item<float>(), 0.35f);
  EXPECT_GE((r > 0).sum(1).min().item<int64_t>(), 4);
  EXPECT_TRUE(torch::allclose(clothed_character().skeleton().rest_joints, rest, 0, 1e-4));
}

TEST(Character, PoseCorrectivesExistNearElbowsAndKnees) {
  const auto& d = character().data();
  ASSERT_TRUE(d.posedirs.defined());
  ASSERT_EQ(d.posedirs.sizes(), (std::vector<int64_t>{character().num_vertices(), 3, 9 * 23}));
  const auto magnitude = d.posedirs.norm(2, 1).amax(0);  // per feature: largest vertex offset
  for (const char* name : {"left_elbow", "right_elbow", "left_knee", "right_knee"}) {
    const int64_t base = 9 * (joint(name) - 1);
    EXPECT_GT(magnitude[base].item<float>(), 0.002f) << name;
    EXPECT_GT(magnitude[base + 8].item<float>(), 0.002f) << name;
    EXPECT_EQ(magnitude[base + 1].item<float>(), 0.0f) << name;  // off-diagonal: none
  }
  EXPECT_EQ(magnitude[9 * (joint("head") - 1)].item<float>(), 0.0f);
  // Bending an elbow by 90 degrees bulges vertices by ~1 cm, not more than 2 cm.
  auto pose = torch::zeros({1, 24, 3});
  pose[0][joint("left_elbow")][1] = -M_PI / 2;
  const auto features = pose_features(torch::eye(3).expand({1, 24, 3, 3}).clone());
  EXPECT_EQ(features.abs().max().item<float>(), 0.0f);
  const auto posed = character().pose(pose);
  auto no_correctives = d;
  no_correctives.posedirs = torch::Tensor();
  const auto plain = BodyModel(no_correctives, "test").pose(pose);
  const auto offset = (posed.vertices - plain.vertices).norm(2, 2).max().item<float>();
  EXPECT_GT(offset, 0.005f);
  EXPECT_LT(offset, 0.02f);
}

TEST(Character, ZeroPoseReturnsTheTemplate) {
  const auto posed = character().pose(torch::zeros({2, 24, 3}));
  EXPECT_TRUE(torch::allclose(posed.vertices[1], character().data().v_template, 0, 1e-6));
}

TEST(Character, BentElbowMovesTheForearmNotTheTorso) {
  const auto& d = character().data();
  const auto rest = character().skeleton().rest_joints;
  auto pose = torch::zeros({1, 24, 3});
  pose[0][joint("left_elbow")][1] = -M_PI / 2;  // forearm swings forward (+z)
  const auto moved = (character().pose(pose).vertices[0] - d.v_template).norm(2, 1);
  const auto x = d.v_template.select(1, 0);
  const float elbow_x = rest[joint("left_elbow")][0].item<float>();
  const float wrist_x = rest[joint("left_wrist")][0].item<float>();
  const auto forearm = (x > elbow_x + 0.5f * (wrist_x - elbow_x));
  const auto torso = x.abs() < 0.12f;
  EXPECT_GT(moved.index({forearm}).min().item<float>(), 0.05f);
  EXPECT_LT(moved.index({torso}).max().item<float>(), 1e-4f);
  // The hand ends up in front of the elbow.
  const int64_t tip = x.argmax().item<int64_t>();
  EXPECT_GT(character().pose(pose).vertices[0][tip][2].item<float>(),
            rest[joint("left_elbow")][2].item<float>() + 0.3f);
}

TEST(Character, SkirtFollowsTheLegsSmoothly) {
  const auto& d = clothed_character().data();
  const auto skeleton = clothed_character().skeleton();
  // Skirt vertices: above the knees, outside the body's thighs, below the waist.
  const auto v = d.v_template;
  const auto y = v.select(1, 1);
  const float knee_y = skeleton.rest_joints[joint("left_knee")][1].item<float>();
  const float hip_y = skeleton.rest_joints[joint("left_hip")][1].item<float>();
  const auto hem = (y > knee_y) & (y < 0.5f * (knee_y + hip_y)) & (v.select(1, 0).abs() > 0.2f);
  ASSERT_GT(hem.sum().item<int64_t>(), 10);
  const auto w = d.weights.index({hem});
  const auto legs = w.index({torch::indexing::Slice(), joint("left_hip")}) +
                    w.index({torch::indexing::Slice(), joint("right_hip")}) +
                    w.index({torch::indexing::Slice(), joint("left_knee")}) +
                    w.index({torch::indexing::Slice(), joint("right_knee")});
  EXPECT_GT(legs.min().item<float>(), 0.5f);
  // Raising one leg drags the skirt on that side forward, less than the knee.
  auto pose = torch::zeros({1, 24, 3});
  pose[0][joint("left_hip")][0] = -0.8f;
  const auto posed = clothed_character().pose(pose);
  const auto dz = (posed.vertices[0] - v).select(1, 2);
  const auto left_hem = hem & (v.select(1, 0) > 0);
  EXPECT_GT(dz.index({left_hem}).mean().item<float>(), 0.02f);
  EXPECT_LT(dz.index({left_hem}).max().item<float>(),
            posed.joints[0][joint("left_knee")][2].item<float>());
}

TEST(Character, SkirtHemFlaresOutWithEitherHipBeyondWhatLbsDoes) {
  const auto& d = clothed_character().data();
  const auto skeleton = clothed_character().skeleton();
  const auto v = d.v_template;
  const auto y = v.select(1, 1), x = v.select(1, 0);
  const float knee_y = skeleton.rest_joints[joint("left_knee")][1].item<float>();
  const float hip_y = skeleton.rest_joints[joint("left_hip")][1].item<float>();
  const auto hem = (y > knee_y) & (y < 0.5f * (knee_y + hip_y)) & (x.abs() > 0.2f);
  BodyModelData lbs_only = d;
  lbs_only.posedirs = torch::zeros_like(d.posedirs);
  const BodyModel without_correctives(lbs_only, "clothed character without correctives");
  // Raise the left leg only: both sides of the hem move outward in x, which a
  // rotation about x cannot do by itself.
  auto pose = torch::zeros({1, 24, 3});
  pose[0][joint("left_hip")][0] = -0.8f;
  const auto flare = (clothed_character().pose(pose).vertices[0] -
                      without_correctives.pose(pose).vertices[0])
                         .select(1, 0);
  EXPECT_GT(flare.index({hem & (x > 0)}).mean().item<float>(), 0.004f);
  EXPECT_LT(flare.index({hem & (x < 0)}).mean().item<float>(), -0.004f);
  // The plain character has no flare: its correctives are local bulges only.
  BodyModelData plain_lbs = character().data();
  plain_lbs.posedirs = torch::zeros_like(plain_lbs.posedirs);
  const auto plain = (character().pose(pose).vertices[0] -
                      BodyModel(plain_lbs, "plain").pose(pose).vertices[0])
                         .select(1, 0);
  const auto plain_x = character().data().v_template.select(1, 0);
  const auto plain_y = character().data().v_template.select(1, 1);
  const auto plain_right_thigh =
      (plain_y > knee_y) & (plain_y < 0.5f * (knee_y + hip_y)) & (plain_x < 0);
  EXPECT_LT(plain.index({plain_right_thigh}).abs().max().item<float>(), 1e-3f);
}

TEST(Character, DeterministicPerSeedAndVariesAcrossSeeds) {
  const auto a = make_character(low_resolution(7));
  const int threads = at::get_num_threads();
  at::set_num_threads(1);
  const auto b = make_character(low_resolution(7));
  at::set_num_threads(threads);
  for (const auto& [x, y] : {std::pair{a.v_template, b.v_template},
                             {a.faces, b.faces},
                             {a.weights, b.weights},
                             {a.J_regressor, b.J_regressor},
                             {a.posedirs, b.posedirs},
                             {a.shapedirs, b.shapedirs}})
    EXPECT_TRUE(torch::equal(x, y));
  const auto c = make_character(low_resolution(8));
  EXPECT_FALSE(a.v_template.sizes() == c.v_template.sizes() &&
               torch::equal(a.v_template, c.v_template));
}

TEST(Character, ShapeDirectionsChangeHeightAndGirth) {
  const auto posed =
      character().pose(torch::zeros({2, 24, 3}), torch::tensor({{1.0f, 0.0f}, {0.0f, 1.0f}}));
  const auto rest = character().data().v_template;
  const float height = rest.select(1, 1).max().item<float>();
  EXPECT_NEAR(posed.vertices[0].select(1, 1).max().item<float>(), height * 1.03f, 0.005f);
  EXPECT_GT(signed_volume(Mesh{posed.vertices[1].contiguous(), character().data().faces, {}}),
            signed_volume(character().template_mesh()) * 1.05);
}

TEST(Character, CommandLineWritesAModelThatLoadsBackIdentically) {
  const auto dir = testing::temp_dir("character_cli");
  const std::string model = (dir / "model.npz").string(), poses = (dir / "poses.npz").string(),
                    mesh = (dir / "template.ply").string();
  const std::string command =
      std::string(FSKIN_CLI_PATH) + " character --resolution 40 --seed 3 --clothed --out " + model +
      " --mesh-out " + mesh + " --write-poses " + poses + " > " + (dir / "log.txt").string();
  ASSERT_EQ(std::system(command.c_str()), 0);
  const auto loaded = BodyModel::load(model);
  auto options = low_resolution(3, true);
  options.resolution = 40;
  const auto expected = make_character(options);
  EXPECT_TRUE(torch::equal(loaded.data().v_template, expected.v_template));
  EXPECT_TRUE(torch::equal(loaded.data().faces, expected.faces));
  EXPECT_TRUE(torch::equal(loaded.data().weights, expected.weights));
  EXPECT_TRUE(torch::equal(loaded.data().posedirs, expected.posedirs));
  EXPECT_EQ(loaded.data().joint_names, smpl_joint_names());
  EXPECT_EQ(loaded.data().parents, smpl_parents());
  const auto set = PoseSet::load(poses);
  set.validate(poses, 24, smpl_joint_names());
  EXPECT_EQ(set.size(), 5);
  EXPECT_TRUE(std::filesystem::exists(mesh));
  // Out-of-range options fail with a message, not a crash.
  const std::string bad = std::string(FSKIN_CLI_PATH) + " character --resolution 4 --out " + model +
                          " 2> " + (dir / "err.txt").string();
  EXPECT_EQ(WEXITSTATUS(std::system(bad.c_str())), 1);
  std::filesystem::remove_all(dir);
}

TEST(Character, RejectsBadOptions) {
  const auto expect_rejected = [](void (*change)(CharacterOptions&), const std::string& option) {
    CharacterOptions options;
    change(options);
    testing::expect_error([&] { make_character(options); }, {"character", option});
  };
  expect_rejected([](CharacterOptions& o) { o.resolution = 4; }, "--resolution");
  expect_rejected([](CharacterOptions& o) { o.height = -1; }, "--height");
  expect_rejected([](CharacterOptions& o) { o.girth = 3; }, "--girth");
  expect_rejected([](CharacterOptions& o) { o.variation = 0.5; }, "--variation");
}

}  // namespace
}  // namespace fskin
