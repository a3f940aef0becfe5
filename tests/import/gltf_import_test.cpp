// Rigged characters through glTF and back: the built-in characters exported
// as skinned glTF (export/skinned_gltf.h) and imported (import/gltf_import.h)
// give the same mesh, weights, skeleton and poses; files that cannot be used
// are errors that name the file and the problem.
#include "fskin/import/gltf_import.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include "fskin/body/character.h"
#include "fskin/body/quadruped.h"
#include "fskin/data/pose_generators.h"
#include "fskin/export/gltf_animation.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/skeleton/rotations.h"
#include "fskin/util/atomic_file.h"
#include "io/gltf_file.h"
#include "import/rig_fixtures.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

class GltfRoundTrip : public ::testing::TestWithParam<bool> {};

TEST_P(GltfRoundTrip, GivesTheSameMeshWeightsSkeletonAndPoses) {
  const auto dir = testing::temp_dir("gltf_round_trip");
  const auto model = testing::small_model(GetParam());
  const auto character = testing::skinned(model, 6);
  const auto path = (dir / "character.glb").string();
  write_skinned_gltf(path, character);
  const auto imported = import_gltf(path);
  const auto& d = imported.model;
  EXPECT_TRUE(torch::allclose(d.v_template, character.mesh.vertices, 0, 1e-5));
  EXPECT_TRUE(torch::equal(d.faces, character.mesh.faces));
  EXPECT_LT((d.weights - testing::top4_dense(character.weights)).abs().max().item<float>(), 1e-5);
  EXPECT_EQ(d.joint_names, character.skeleton.joint_names);
  EXPECT_EQ(d.parents, character.skeleton.parents);
  EXPECT_LT((d.rest_joints - character.skeleton.rest_joints).abs().max().item<float>(), 1e-5);
  ASSERT_EQ(imported.clips.size(), 1u);
  const auto& clip = imported.clips[0];
  EXPECT_EQ(clip.name, "poses");
  EXPECT_NEAR(clip.fps, 24, 1e-3);
  ASSERT_EQ(clip.poses.size(), 6);
  const auto expected = axis_angle_to_matrix(character.animation.poses);
  const auto got = axis_angle_to_matrix(clip.poses.poses);
  EXPECT_LT((got - expected).abs().max().item<float>(), 1e-5);
  EXPECT_LT((clip.poses.trans - character.animation.trans).abs().max().item<float>(), 1e-5);
  EXPECT_LT(clip.max_joint_drift, 1e-5);
  // The imported model poses like the original with its top-4 weights.
  BodyModelData reference = model.data();
  reference.weights = testing::top4_dense(reference.weights);
  reference.posedirs = torch::Tensor();
  const auto a = BodyModel(reference, "reference").pose(character.animation.poses, {}, character.animation.trans);
  const auto b = BodyModel(d, path).pose(clip.poses.poses, {}, clip.poses.trans);
  EXPECT_LT((a.vertices - b.vertices).abs().max().item<float>(), 1e-4);
  // Clips come out as one pose file with their names.
  const auto clips = concatenate_clips(imported.clips);
  clips.save((dir / "clips.npz").string());
  EXPECT_EQ(PoseSet::load((dir / "clips.npz").string()).clip_names, std::vector<std::string>{"poses"});
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(BuiltInCharacters, GltfRoundTrip, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "quadruped" : "humanoid"; });

// Rigs animate the translations of non-root joints (stretchy spines,
// sliding props): the export writes them as translation channels, the import
// recovers them, and the model poses as the original.
TEST(GltfImport, ClipsKeepNonRootJointTranslations) {
  const auto dir = testing::temp_dir("gltf_joint_translations");
  const auto model = testing::small_model(false);
  auto character = testing::skinned(model, 4);
  const int64_t J = model.num_joints();
  torch::manual_seed(2);
  auto moved = torch::randn({4, J, 3}) * 0.03;
  moved.select(1, 0).zero_();
  character.animation.joint_translations = moved;
  const auto path = (dir / "stretchy.glb").string();
  write_skinned_gltf(path, character);
  const auto imported = import_gltf(path);
  ASSERT_EQ(imported.clips.size(), 1u);
  const auto& clip = imported.clips[0].poses;
  ASSERT_TRUE(clip.joint_translations.defined());
  EXPECT_LT((clip.joint_translations - moved).abs().max().item<float>(), 1e-5);
  EXPECT_GT(imported.clips[0].max_joint_drift, 0.01);
  BodyModelData reference = model.data();
  reference.weights = testing::top4_dense(reference.weights);
  reference.posedirs = torch::Tensor();
  const auto& anim = character.animation;
  const auto a = BodyModel(reference, "reference").pose(anim.poses, {}, anim.trans, moved);
  const auto b = BodyModel(imported.model, path).pose(clip.poses, {}, clip.trans, clip.joint_translations);
  EXPECT_LT((a.vertices - b.vertices).abs().max().item<float>(), 1e-4);
  bool noted = false;
  for (const auto& note : imported.notes) noted |= note.find("kept as joint translations") != std::string::npos;
  EXPECT_TRUE(noted);
  // And through a pose file.
  concatenate_clips(imported.clips).save((dir / "clips.npz").string());
  EXPECT_TRUE(torch::equal(PoseSet::load((dir / "clips.npz").string()).joint_translations, clip.joint_translations));
  fs::remove_all(dir);
}

// DCC tools give joints rest rotations (bone frames along the bones): turn
// every joint's frame by its own rotation Q_j (locals Q_p^T L_j Q_j, inverse
// bind matrices Q_j^T IBM_j, animated rotations likewise). The skinning is
// unchanged, so the import must be too.
TEST(GltfImport, JointRestRotationsDoNotChangeTheImport) {
  const auto dir = testing::temp_dir("gltf_rest_rotations");
  const auto model = testing::small_model(false);
  const auto character = testing::skinned(model, 4);
  const auto plain = (dir / "plain.glb").string(), turned = (dir / "turned.glb").string();
  write_skinned_gltf(plain, character);
  auto gltf = gltf::load(plain);
  const int64_t J = character.skeleton.num_joints();
  torch::manual_seed(11);
  const auto q = axis_angle_to_matrix(torch::randn({J, 3}, torch::kFloat64));  // [J, 3, 3]
  const auto& parents = character.skeleton.parents;
  const auto q_parent = [&](int64_t j) { return parents[j] < 0 ? torch::eye(3, torch::kFloat64) : q[parents[j]]; };
  const auto to_quaternion = [](const torch::Tensor& r) {  // glTF (x, y, z, w)
    const auto wxyz = matrix_to_quaternion(r);
    return std::vector<double>{wxyz[1].item<double>(), wxyz[2].item<double>(), wxyz[3].item<double>(),
                               wxyz[0].item<double>()};
  };
  for (int64_t j = 0; j < J; ++j) {
    auto& node = gltf.nodes[j];
    const auto t = torch::tensor(node.translation, torch::kFloat64);
    const auto turned_t = torch::matmul(q_parent(j).t(), t);
    node.translation = {turned_t[0].item<double>(), turned_t[1].item<double>(), turned_t[2].item<double>()};
    node.rotation = to_quaternion(torch::matmul(q_parent(j).t(), q[j]));  // rest rotation: identity before
  }
  // Inverse bind matrices (column-major MAT4) and animated rotations, rewritten in place.
  const auto write_floats = [&](int accessor, const std::vector<double>& values) {
    const auto& a = gltf.accessors[accessor];
    const auto& view = gltf.bufferViews[a.bufferView];
    auto* out = reinterpret_cast<float*>(gltf.buffers[view.buffer].data.data() + view.byteOffset + a.byteOffset);
    for (size_t i = 0; i < values.size(); ++i) out[i] = static_cast<float>(values[i]);
  };
  const int ibm = gltf.skins[0].inverseBindMatrices;
  auto ibms = gltf::read_accessor(gltf, ibm, TINYGLTF_TYPE_MAT4, plain, "ibm");
  for (int64_t j = 0; j < J; ++j) {
    const auto m = torch::tensor(std::vector<double>(ibms.begin() + 16 * j, ibms.begin() + 16 * j + 16), torch::kFloat64)
                       .view({4, 4})
                       .t();  // row-major
    auto qt = torch::eye(4, torch::kFloat64);
    qt.narrow(0, 0, 3).narrow(1, 0, 3).copy_(q[j].t());
    const auto turned_m = torch::matmul(qt, m).t().contiguous();
    for (int k = 0; k < 16; ++k) ibms[16 * j + k] = turned_m.view({16})[k].item<double>();
  }
  write_floats(ibm, ibms);
  for (const auto& channel : gltf.animations[0].channels) {
    if (channel.target_path != "rotation") continue;
    const int64_t j = channel.target_node;
    const int output = gltf.animations[0].samplers[channel.sampler].output;
    auto values = gltf::read_accessor(gltf, output, TINYGLTF_TYPE_VEC4, plain, "rotation");
    for (size_t k = 0; k < values.size(); k += 4) {
      const auto r = quaternion_to_matrix(torch::tensor({values[k + 3], values[k], values[k + 1], values[k + 2]}, torch::kFloat64));
      const auto turned_q = to_quaternion(torch::matmul(torch::matmul(q_parent(j).t(), r), q[j]));
      std::copy(turned_q.begin(), turned_q.end(), values.begin() + k);
    }
    write_floats(output, values);
  }
  gltf::save(turned, gltf, true);
  const auto a = import_gltf(plain), b = import_gltf(turned);
  EXPECT_LT((a.model.rest_joints - b.model.rest_joints).abs().max().item<float>(), 1e-5);
  EXPECT_TRUE(torch::equal(a.model.weights, b.model.weights));
  ASSERT_EQ(b.clips.size(), 1u);
  const auto ra = axis_angle_to_matrix(a.clips[0].poses.poses), rb = axis_angle_to_matrix(b.clips[0].poses.poses);
  EXPECT_LT((ra - rb).abs().max().item<float>(), 1e-4);
  EXPECT_LT((a.clips[0].poses.trans - b.clips[0].poses.trans).abs().max().item<float>(), 1e-5);
  EXPECT_LT(b.clips[0].max_joint_drift, 1e-4);
  fs::remove_all(dir);
}

TEST(GltfImport, WeldsSeamDuplicatesIntoAClosedSurface) {
  // A glTF exporter splits vertices at UV seams: duplicate every vertex of
  // one half of the faces; welding must restore the closed mesh.
  const auto dir = testing::temp_dir("gltf_weld");
  const auto model = testing::small_model(false);
  auto character = testing::skinned(model, 0);
  const int64_t V = character.mesh.num_vertices(), F = character.mesh.num_faces();
  character.mesh.vertices = torch::cat({character.mesh.vertices, character.mesh.vertices});
  character.weights = torch::cat({character.weights, character.weights});
  auto faces = character.mesh.faces.clone();
  faces.slice(0, 0, F / 2).add_(V);
  character.mesh.faces = faces;
  const auto path = (dir / "seams.glb").string();
  write_skinned_gltf(path, character);
  const auto imported = import_gltf(path);
  EXPECT_EQ(imported.model.v_template.size(0), V);
  EXPECT_TRUE(imported.clips.empty());
  EXPECT_NE(imported.notes.front().find("welded"), std::string::npos);
  fs::remove_all(dir);
}

TEST(GltfImport, UnusableFilesNameTheFileAndTheProblem) {
  const auto dir = testing::temp_dir("gltf_bad_import");
  // No skin: a morph-target animation.
  MeshAnimation animation;
  animation.faces = torch::tensor({{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {1, 3, 2}}, torch::kInt64);
  animation.frames = torch::tensor({{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {0.f, 1.f, 0.f}, {0.f, 0.f, 1.f}}).unsqueeze(0);
  const auto unskinned = (dir / "unskinned.glb").string();
  write_gltf_animation(unskinned, animation);
  testing::expect_error([&] { import_gltf(unskinned); }, {"unskinned.glb", "no skinned mesh"});
  // No closed part: one face removed.
  const auto model = testing::small_model(false);
  auto open = testing::skinned(model, 0);
  open.mesh.faces = open.mesh.faces.slice(0, 1);
  const auto holes = (dir / "holes.glb").string();
  write_skinned_gltf(holes, open);
  testing::expect_error([&] { import_gltf(holes); }, {"holes.glb", "closed"});
  // Two roots: cut the link from the root joint to its first child.
  const auto two_roots = (dir / "two_roots.gltf").string();
  write_skinned_gltf(two_roots, testing::skinned(model, 0));
  auto json = nlohmann::json::parse(read_file(two_roots));
  auto& children = json["nodes"][0]["children"];
  const auto first_child = children[0].get<int>();
  children.erase(children.begin());
  json["scenes"][0]["nodes"].push_back(first_child);
  write_file_atomically(two_roots, json.dump());
  testing::expect_error([&] { import_gltf(two_roots); }, {"two_roots.gltf", "2 roots", "pelvis"});
  testing::expect_error([&] { import_gltf((dir / "missing.glb").string()); }, {"missing.glb", "no such file"});
  fs::remove_all(dir);
}

TEST(SkinnedGltf, PassesTheKhronosValidatorAndLoadsInThreeJs) {
  const auto dir = testing::temp_dir("skinned_gltf_check");
  const auto model = testing::small_model(true);
  const auto glb = (dir / "quadruped.glb").string(), log = (dir / "check.log").string();
  // Four influences (what engines read) and every influence (9 sets of four).
  for (const int64_t influences : {4, 0}) {
    auto character = testing::skinned(model, 4);
    character.influences = influences;
    write_skinned_gltf(glb, character);
    const std::string command = "node " + std::string(FSKIN_GLTF_CHECK) + " " + glb + " > " + log + " 2>&1";
    const int status = std::system(command.c_str());
    const std::string output = read_file(log);
    ASSERT_EQ(status, 0) << output << "\n(scripts/setup.sh installs node and the checkers)";
    EXPECT_NE(output.find("\"errors\":0,\"warnings\":0"), std::string::npos) << influences << ": " << output;
    EXPECT_NE(output.find("\"skinned\":true,\"bones\":33,\"clips\":1"), std::string::npos) << output;
  }
  // Every influence imports back as the exact weights.
  auto exact = testing::skinned(model, 0);
  exact.influences = 0;
  write_skinned_gltf(glb, exact);
  EXPECT_LT((import_gltf(glb).model.weights - model.data().weights).abs().max().item<float>(), 1e-5);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fskin
