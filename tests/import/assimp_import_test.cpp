// Rigged characters through assimp (import/assimp_import.h): the same glTF
// read by both readers gives the same model and clips; a Collada file in
// centimetres with +Z up, written here from a built-in character, comes back
// in metres with +Y up; the FBX rigs of Debian's assimp-testmodels import
// with their skeletons and clips.
#include "fskin/import/assimp_import.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <fstream>
#include <functional>

#include "fskin/geometry/character_size.h"
#include "fskin/import/gltf_import.h"
#include "fskin/skeleton/rotations.h"
#include "import/rig_fixtures.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

float max_difference(const torch::Tensor& a, const torch::Tensor& b) { return (a - b).abs().max().item<float>(); }

TEST(AssimpImport, ReadsAGltfRigLikeTheGltfReader) {
  const auto dir = testing::temp_dir("assimp_gltf");
  const auto model = testing::small_model(true);
  const auto path = (dir / "quadruped.glb").string();
  write_skinned_gltf(path, testing::skinned(model, 5));
  const auto a = import_gltf(path), b = import_with_assimp(path);
  EXPECT_EQ(a.model.joint_names, b.model.joint_names);
  EXPECT_EQ(a.model.parents, b.model.parents);
  EXPECT_LT(max_difference(a.model.rest_joints, b.model.rest_joints), 1e-5);
  EXPECT_LT(max_difference(a.model.v_template, b.model.v_template), 1e-5);
  EXPECT_TRUE(torch::equal(a.model.faces, b.model.faces));
  EXPECT_LT(max_difference(a.model.weights, b.model.weights), 1e-5);
  ASSERT_EQ(b.clips.size(), 1u);
  EXPECT_EQ(b.clips[0].poses.size(), 5);
  EXPECT_NEAR(b.clips[0].fps, 24, 1e-3);
  EXPECT_LT(max_difference(axis_angle_to_matrix(a.clips[0].poses.poses), axis_angle_to_matrix(b.clips[0].poses.poses)),
            1e-4);
  EXPECT_LT(max_difference(a.clips[0].poses.trans, b.clips[0].poses.trans), 1e-5);
  fs::remove_all(dir);
}

// Collada 1.4 as DCC tools write it, by hand because assimp's own Collada
// and FBX writers produce files its readers reject (assimp 5.2.5). The file
// is in centimetres with +Z up: file = A^-1 p / 0.01 with A the Z_UP -> Y_UP
// turn (x, y, z) -> (x, z, -y). Joint nodes carry matrices; each joint is
// animated by a float4x4 channel with `keys` keyframes at 24 fps.
struct ColladaRig {
  SkinnedCharacter character;
  torch::Tensor rotations;  // [K, J, 3] animated local rotations
  torch::Tensor trans;      // [K, 3]
};

void write_collada(const std::string& path, const ColladaRig& rig) {
  const auto& c = rig.character;
  const auto& names = c.skeleton.joint_names;
  const auto& parents = c.skeleton.parents;
  const int64_t J = c.skeleton.num_joints(), V = c.mesh.num_vertices(), K = rig.rotations.size(0);
  auto A = torch::tensor({{1.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, {0.0, -1.0, 0.0}}, torch::kFloat64);  // file -> fskin
  const auto to_file = [&](const torch::Tensor& p) { return torch::matmul(A.t(), p.to(torch::kFloat64)) / 0.01; };
  const auto numbers = [](const torch::Tensor& t) {
    std::string s;
    const auto flat = t.to(torch::kFloat64).contiguous().view({-1});
    for (int64_t i = 0; i < flat.numel(); ++i) s += fmt::format("{:.10g} ", flat[i].item<double>());
    return s;
  };
  const auto matrix = [&](const torch::Tensor& rotation_fskin, const torch::Tensor& translation_fskin) {
    auto m = torch::eye(4, torch::kFloat64);
    m.narrow(0, 0, 3).narrow(1, 0, 3).copy_(torch::matmul(torch::matmul(A.t(), rotation_fskin.to(torch::kFloat64)), A));
    m.narrow(0, 0, 3).select(1, 3).copy_(to_file(translation_fskin));
    return m;  // row-major text, as Collada writes matrices
  };
  const auto rest = c.skeleton.rest_joints.to(torch::kFloat64);
  const auto offset = [&](int64_t j) { return parents[j] < 0 ? rest[j] : rest[j] - rest[parents[j]]; };
  std::string out = R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><unit name="centimeter" meter="0.01"/><up_axis>Z_UP</up_axis></asset>
<library_geometries><geometry id="body-mesh" name="body"><mesh>
)";
  const auto file_vertices = torch::matmul(c.mesh.vertices.to(torch::kFloat64), A) / 0.01;  // rows: A^T p
  out += fmt::format(R"(<source id="body-positions"><float_array id="body-positions-array" count="{}">{}</float_array>
<technique_common><accessor source="#body-positions-array" count="{}" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="body-vertices"><input semantic="POSITION" source="#body-positions"/></vertices>
<triangles count="{}"><input semantic="VERTEX" source="#body-vertices" offset="0"/><p>{}</p></triangles>
</mesh></geometry></library_geometries>
)",
                     3 * V, numbers(file_vertices), V, c.mesh.num_faces(), numbers(c.mesh.faces));
  std::string joint_names, binds, weights, vcount, v;
  int64_t w_count = 0;
  for (int64_t j = 0; j < J; ++j) {
    joint_names += names[j] + " ";
    binds += numbers(matrix(torch::eye(3), -rest[j]));
  }
  const auto w = c.weights.to(torch::kFloat64);
  for (int64_t i = 0; i < V; ++i) {
    int64_t n = 0;
    for (int64_t j = 0; j < J; ++j) {
      const double value = w[i][j].item<double>();
      if (value <= 0) continue;
      weights += fmt::format("{:.10g} ", value);
      v += fmt::format("{} {} ", j, w_count++);
      ++n;
    }
    vcount += fmt::format("{} ", n);
  }
  out += fmt::format(R"(<library_controllers><controller id="body-skin"><skin source="#body-mesh">
<bind_shape_matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</bind_shape_matrix>
<source id="skin-joints"><Name_array id="skin-joints-array" count="{0}">{1}</Name_array><technique_common><accessor source="#skin-joints-array" count="{0}" stride="1"><param name="JOINT" type="name"/></accessor></technique_common></source>
<source id="skin-bind"><float_array id="skin-bind-array" count="{2}">{3}</float_array><technique_common><accessor source="#skin-bind-array" count="{0}" stride="16"><param name="TRANSFORM" type="float4x4"/></accessor></technique_common></source>
<source id="skin-weights"><float_array id="skin-weights-array" count="{4}">{5}</float_array><technique_common><accessor source="#skin-weights-array" count="{4}" stride="1"><param name="WEIGHT" type="float"/></accessor></technique_common></source>
<joints><input semantic="JOINT" source="#skin-joints"/><input semantic="INV_BIND_MATRIX" source="#skin-bind"/></joints>
<vertex_weights count="{6}"><input semantic="JOINT" source="#skin-joints" offset="0"/><input semantic="WEIGHT" source="#skin-weights" offset="1"/><vcount>{7}</vcount><v>{8}</v></vertex_weights>
</skin></controller></library_controllers>
<library_animations>
)",
                     J, joint_names, 16 * J, binds, w_count, weights, V, vcount, v);
  std::string times, interpolation;
  for (int64_t k = 0; k < K; ++k) {
    times += fmt::format("{:.10g} ", k / 24.0);
    interpolation += "LINEAR ";
  }
  const auto rotations = axis_angle_to_matrix(rig.rotations.to(torch::kFloat64));
  for (int64_t j = 0; j < J; ++j) {
    std::string keys;
    for (int64_t k = 0; k < K; ++k)
      keys += numbers(matrix(rotations[k][j], parents[j] < 0 ? offset(j) + rig.trans[k].to(torch::kFloat64) : offset(j)));
    const auto& n = names[j];
    out += fmt::format(R"(<animation id="anim-{0}">
<source id="anim-{0}-input"><float_array id="anim-{0}-input-array" count="{1}">{2}</float_array><technique_common><accessor source="#anim-{0}-input-array" count="{1}" stride="1"><param name="TIME" type="float"/></accessor></technique_common></source>
<source id="anim-{0}-output"><float_array id="anim-{0}-output-array" count="{3}">{4}</float_array><technique_common><accessor source="#anim-{0}-output-array" count="{1}" stride="16"><param name="TRANSFORM" type="float4x4"/></accessor></technique_common></source>
<source id="anim-{0}-interpolation"><Name_array id="anim-{0}-interpolation-array" count="{1}">{5}</Name_array><technique_common><accessor source="#anim-{0}-interpolation-array" count="{1}" stride="1"><param name="INTERPOLATION" type="name"/></accessor></technique_common></source>
<sampler id="anim-{0}-sampler"><input semantic="INPUT" source="#anim-{0}-input"/><input semantic="OUTPUT" source="#anim-{0}-output"/><input semantic="INTERPOLATION" source="#anim-{0}-interpolation"/></sampler>
<channel source="#anim-{0}-sampler" target="{0}/transform"/>
</animation>
)",
                       n, K, times, 16 * K, keys, interpolation);
  }
  out += "</library_animations>\n<library_visual_scenes><visual_scene id=\"scene\" name=\"scene\">\n";
  std::function<void(int64_t)> node = [&](int64_t j) {
    out += fmt::format(R"(<node id="{0}" name="{0}" sid="{0}" type="JOINT"><matrix sid="transform">{1}</matrix>)", names[j],
                       numbers(matrix(torch::eye(3), offset(j))));
    for (int64_t k = 0; k < J; ++k)
      if (parents[k] == j) node(k);
    out += "</node>\n";
  };
  node(0);
  out += fmt::format(R"(<node id="body" name="body"><instance_controller url="#body-skin"><skeleton>#{}</skeleton></instance_controller></node>
</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
)",
                     names[0]);
  std::ofstream(path) << out;
}

TEST(AssimpImport, ColladaInCentimetresWithZUpComesBackInMetresWithYUp) {
  const auto dir = testing::temp_dir("assimp_collada");
  const auto model = testing::small_model(false);
  ColladaRig rig;
  rig.character = testing::skinned(model, 0);
  torch::manual_seed(5);
  const int64_t J = model.num_joints();
  rig.rotations = torch::randn({3, J, 3}) * 0.3;
  rig.trans = torch::randn({3, 3}) * 0.2;
  const auto path = (dir / "character.dae").string();
  write_collada(path, rig);
  const auto imported = import_with_assimp(path);
  const auto& d = imported.model;
  const auto& c = rig.character;
  EXPECT_EQ(d.joint_names, c.skeleton.joint_names);
  EXPECT_EQ(d.parents, c.skeleton.parents);
  EXPECT_LT(max_difference(d.rest_joints, c.skeleton.rest_joints), 1e-5);
  // assimp's Collada reader splits vertices per face corner; welding joins
  // them again in the order the faces first use them.
  ASSERT_EQ(d.v_template.size(0), c.mesh.num_vertices());
  const auto [distance, original] = torch::cdist(d.v_template.to(torch::kFloat64), c.mesh.vertices.to(torch::kFloat64)).min(1);
  EXPECT_LT(distance.max().item<float>(), 1e-5);
  EXPECT_TRUE(torch::equal(original.index_select(0, d.faces.flatten()).view({-1, 3}), c.mesh.faces));
  EXPECT_LT(max_difference(d.weights, c.weights.index_select(0, original)), 1e-5);
  ASSERT_EQ(imported.clips.size(), 1u);
  const auto& clip = imported.clips[0];
  ASSERT_EQ(clip.poses.size(), 3);
  EXPECT_NEAR(clip.fps, 24, 1e-3);
  EXPECT_LT(max_difference(axis_angle_to_matrix(clip.poses.poses), axis_angle_to_matrix(rig.rotations)), 1e-4);
  EXPECT_LT(max_difference(clip.poses.trans, rig.trans), 1e-5);
  EXPECT_LT(clip.max_joint_drift, 1e-5);
  fs::remove_all(dir);
}

// Debian's assimp-testmodels (BSD-3-Clause): two small FBX rigs exported
// from Blender, in centimetres, with one clip each.
struct FbxRig {
  const char* file;
  int64_t joints;
  const char* root;
  int64_t frames;
  double fps;
};

class AssimpFbx : public ::testing::TestWithParam<FbxRig> {};

TEST_P(AssimpFbx, ImportsTheSkeletonMeshAndClip) {
  const auto& rig = GetParam();
  const std::string path = std::string("/usr/share/assimp/models/FBX/") + rig.file;
  ASSERT_TRUE(fs::exists(path)) << path << " (scripts/setup.sh installs assimp-testmodels)";
  const auto imported = import_with_assimp(path);
  const auto& d = imported.model;
  EXPECT_EQ(static_cast<int64_t>(d.joint_names.size()), rig.joints);
  EXPECT_EQ(d.joint_names.front(), rig.root);
  EXPECT_LT(max_difference(d.weights.sum(1), torch::ones({d.weights.size(0)})), 1e-5);
  EXPECT_NE(imported.notes.front().find("FBX unit 1 cm"), std::string::npos) << imported.notes.front();
  ASSERT_EQ(imported.clips.size(), 1u);
  const auto& clip = imported.clips[0];
  EXPECT_EQ(clip.poses.size(), rig.frames);
  EXPECT_NEAR(clip.fps, rig.fps, 1e-3);
  EXPECT_TRUE(torch::isfinite(clip.poses.poses).all().item<bool>());
  // The clip moves the character and the recovered rotations reproduce its joints.
  EXPECT_GT(clip.poses.poses.abs().max().item<float>(), 0.1);
  EXPECT_LT(clip.max_joint_drift, 1e-4 * character_size(d.v_template));
}

INSTANTIATE_TEST_SUITE_P(TestModels, AssimpFbx,
                         ::testing::Values(FbxRig{"animation_with_skeleton.fbx", 15, "Armature", 14, 24},
                                           FbxRig{"huesitos.fbx", 9, "Bone", 40, 25}),
                         [](const auto& info) {
                           std::string name = info.param.file;
                           return name.substr(0, name.find('.'));
                         });

TEST(AssimpImport, UnusableFilesNameTheFileAndTheProblem) {
  const auto dir = testing::temp_dir("assimp_bad_import");
  testing::expect_error([&] { import_with_assimp((dir / "missing.fbx").string()); }, {"missing.fbx", "no such file"});
  const auto garbage = (dir / "garbage.fbx").string();
  std::ofstream(garbage) << "Kaydara FBX Binary  \x00\x1a\x00 not really";
  testing::expect_error([&] { import_with_assimp(garbage); }, {"garbage.fbx", "cannot read it"});
  testing::expect_error([&] { import_with_assimp("/usr/share/assimp/models/FBX/box.fbx"); },
                        {"box.fbx", "no skinned mesh"});
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fskin
