// Hostile files, one per way a reader has been broken: each must end in an
// fskin::Error that names the file and the problem, never a crash, a hang,
// an out-of-bounds read or a silently accepted value. The cases follow the
// surfaces of `fskin import` (glTF, assimp), `fskin poses import` (BVH,
// AMASS), image datasets, run directories and output paths.
#include <gtest/gtest.h>
#include <torch/torch.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "fskin/body/character.h"
#include "fskin/core/error.h"
#include "fskin/export/image.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/import/assimp_import.h"
#include "fskin/import/gltf_import.h"
#include "fskin/import/motion_import.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/image_metrics.h"
#include "fskin/engine/run_directory.h"
#include "fskin/engine/run_lock.h"
#include "fskin/training/train_config.h"
#include "fskin/util/atomic_file.h"
#include "import/rig_fixtures.h"
#include "io/gltf_file.h"
#include "radiance/tiny_image_dataset.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

void spit(const fs::path& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

// ---- glTF -------------------------------------------------------------------

// The embedded buffers of .gltf files (RFC 4648 base64); tinygltf's own
// codec is internal to its implementation.
constexpr char kBase64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::string base64_encode(const std::string& bytes) {
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const size_t n = std::min<size_t>(3, bytes.size() - i);
    uint32_t v = 0;
    for (size_t k = 0; k < 3; ++k) v = v << 8 | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0);
    for (size_t k = 0; k < 4; ++k) out += k <= n ? kBase64[(v >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

std::string base64_decode(const std::string& text) {
  std::string out;
  uint32_t v = 0;
  int bits = 0;
  for (const char c : text) {
    const char* at = std::strchr(kBase64, c);
    if (c == '=' || !at || !*at) break;
    v = v << 6 | static_cast<uint32_t>(at - kBase64);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((v >> bits) & 0xff);
    }
  }
  return out;
}

// A small skinned rig with a clip, as .gltf JSON (buffer embedded as base64).
const json& rig_gltf() {
  static const json* rig = [] {
    const auto dir = testing::temp_dir("hostile_gltf_seed");
    const auto model = testing::small_model(false);
    const auto path = (dir / "rig.gltf").string();
    write_skinned_gltf(path, testing::skinned(model, 3));
    return new json(json::parse(read_file(path)));
  }();
  return *rig;
}

std::string write_gltf(const json& document, const std::string& name) {
  const auto path = (testing::temp_dir("hostile_gltf") / (name + ".gltf")).string();
  spit(path, document.dump());
  return path;
}

int skinned_primitive_accessor(const json& g, const char* attribute) {
  for (const auto& node : g["nodes"])
    if (node.contains("mesh") && node.contains("skin"))
      return g["meshes"][node["mesh"].get<int>()]["primitives"][0]["attributes"][attribute].get<int>();
  return -1;
}

TEST(HostileGltf, TheUntouchedRigImports) {
  const auto imported = import_gltf(write_gltf(rig_gltf(), "untouched"));
  EXPECT_GT(imported.model.v_template.size(0), 100);
  EXPECT_EQ(imported.clips.size(), 1u);
}

TEST(HostileGltf, ANonIndexedPrimitiveOfAVertexCountNotAMultipleOfThreeIsRefused) {
  json g = rig_gltf();
  for (auto& mesh : g["meshes"])
    for (auto& primitive : mesh["primitives"]) {
      primitive.erase("indices");
      for (auto& [name, accessor] : primitive["attributes"].items()) {
        auto& count = g["accessors"][accessor.get<int>()]["count"];
        count = count.get<int64_t>() / 3 * 3 - 2;  // 1 more than a multiple of 3
      }
    }
  for (const bool keep_open : {false, true}) {
    ImportOptions options;
    options.keep_open_parts = keep_open;
    testing::expect_error([&] { import_gltf(write_gltf(g, "non_indexed"), options); },
                          {"non_indexed.gltf", "no indices", "not a multiple of 3"});
  }
}

TEST(HostileGltf, AByteOffsetNearTwoToTheSixtyFourIsOutOfBoundsNotWrappedAround) {
  for (const uint64_t offset : {~uint64_t{0} - 7, ~uint64_t{0} - 4095, uint64_t{1} << 63}) {
    json g = rig_gltf();
    g["accessors"][skinned_primitive_accessor(g, "POSITION")]["byteOffset"] = offset;
    // tinygltf may refuse the number itself; either way nothing is read.
    EXPECT_THROW(import_gltf(write_gltf(g, "offset")), Error) << offset;
    json h = rig_gltf();
    h["accessors"][h["skins"][0]["inverseBindMatrices"].get<int>()]["byteOffset"] = offset;
    EXPECT_THROW(import_gltf(write_gltf(h, "ibm_offset")), Error) << offset;
  }
}

TEST(HostileGltf, ClaimedCountsBeyondTheBufferAreRefusedBeforeAllocating) {
  for (const uint64_t count : {uint64_t{1} << 62, uint64_t{1} << 40, ~uint64_t{0}}) {
    json g = rig_gltf();
    g["accessors"][skinned_primitive_accessor(g, "POSITION")]["count"] = count;
    EXPECT_THROW(import_gltf(write_gltf(g, "count")), Error) << count;
  }
}

TEST(HostileGltf, AMeshUnderADeepNodeChainImportsWithoutRecursion) {
  json g = rig_gltf();
  const int first = static_cast<int>(g["nodes"].size());
  constexpr int kDepth = 100'000;
  for (int i = 0; i < kDepth; ++i) g["nodes"].push_back(json{{"name", "chain_" + std::to_string(i)}});
  for (int i = 0; i + 1 < kDepth; ++i) g["nodes"][first + i]["children"] = json::array({first + i + 1});
  // The scene's roots go under the chain's last node.
  auto& scene = g["scenes"][0]["nodes"];
  g["nodes"][first + kDepth - 1]["children"] = scene;
  scene = json::array({first});
  const auto imported = import_gltf(write_gltf(g, "deep"));
  const auto reference = import_gltf(write_gltf(rig_gltf(), "shallow"));
  EXPECT_TRUE(torch::allclose(imported.model.v_template, reference.model.v_template));
  ASSERT_EQ(imported.clips.size(), reference.clips.size());
  EXPECT_TRUE(torch::allclose(imported.clips[0].poses.poses, reference.clips[0].poses.poses, 1e-4, 1e-5));
}

TEST(HostileGltf, ANodeCycleIsRefused) {
  json g = rig_gltf();
  const int a = static_cast<int>(g["nodes"].size());
  g["nodes"].push_back(json{{"name", "a"}, {"children", json::array({a + 1})}});
  g["nodes"].push_back(json{{"name", "b"}, {"children", json::array({a})}});
  testing::expect_error([&] { import_gltf(write_gltf(g, "cycle")); }, {"cycle.gltf", "cycle"});
}

TEST(HostileGltf, ABufferUriNamingADirectoryIsRefusedNamingIt) {
  json g = rig_gltf();
  const auto dir = testing::temp_dir("hostile_gltf_dir_uri");
  fs::create_directories(dir / "folder.bin");
  g["buffers"][0]["uri"] = "folder.bin";
  const auto path = (dir / "rig.gltf").string();
  spit(path, g.dump());
  testing::expect_error([&] { import_gltf(path); }, {"rig.gltf"});
}

TEST(HostileGltf, ImplausibleKeyframesAreRefusedNamingTheClip) {
  const auto sampler_input = [](json& g) {
    return g["animations"][0]["samplers"][0]["input"].get<int>();
  };
  // Key times are float accessors in the embedded buffer; rewrite the bytes.
  const auto rewrite = [](json& g, int accessor_index, const std::function<void(float*, size_t)>& edit) {
    const auto& accessor = g["accessors"][accessor_index];
    const auto& view = g["bufferViews"][accessor["bufferView"].get<int>()];
    const std::string uri = g["buffers"][0]["uri"];
    const std::string prefix = "data:application/octet-stream;base64,";
    ASSERT_EQ(uri.rfind(prefix, 0), 0u);
    std::string bytes = base64_decode(uri.substr(prefix.size()));
    const size_t begin = view.value("byteOffset", 0) + accessor.value("byteOffset", 0);
    const size_t count = accessor["count"].get<size_t>() * (accessor["type"] == "SCALAR" ? 1 : accessor["type"] == "VEC3" ? 3 : 4);
    edit(reinterpret_cast<float*>(bytes.data() + begin), count);
    g["buffers"][0]["uri"] =
        prefix + base64_encode(bytes);
  };
  {
    json g = rig_gltf();
    rewrite(g, sampler_input(g), [](float* t, size_t n) { t[n - 1] = std::nanf(""); });
    testing::expect_error([&] { import_gltf(write_gltf(g, "nan_time")); }, {"nan_time.gltf", "key time"});
  }
  {
    json g = rig_gltf();
    rewrite(g, sampler_input(g), [](float* t, size_t n) { std::swap(t[0], t[n - 1]); });
    g["accessors"][sampler_input(g)].erase("min");
    g["accessors"][sampler_input(g)].erase("max");
    testing::expect_error([&] { import_gltf(write_gltf(g, "decreasing")); }, {"decreasing.gltf", "do not increase"});
  }
  for (const auto& channel : rig_gltf()["animations"][0]["channels"]) {
    if (channel["target"]["path"] != "rotation") continue;
    json g = rig_gltf();
    const int output = g["animations"][0]["samplers"][channel["sampler"].get<int>()]["output"];
    rewrite(g, output, [](float* q, size_t) { q[0] = q[1] = q[2] = q[3] = 0; });
    testing::expect_error([&] { import_gltf(write_gltf(g, "zero_quaternion")); },
                          {"zero_quaternion.gltf", "quaternion of length 0"});
    break;
  }
  for (const auto& channel : rig_gltf()["animations"][0]["channels"]) {
    if (channel["target"]["path"] != "translation") continue;
    json g = rig_gltf();
    const int output = g["animations"][0]["samplers"][channel["sampler"].get<int>()]["output"];
    rewrite(g, output, [](float* v, size_t) { v[0] = 1e30f; });
    g["accessors"][output].erase("min");
    g["accessors"][output].erase("max");
    testing::expect_error([&] { import_gltf(write_gltf(g, "far")); }, {"far.gltf", "times the character's size"});
    break;
  }
}

// read_accessor on hand-made models: sparse substitution (glTF 2.0 sec.
// 3.6.2.3) and its bounds.
tinygltf::Model sparse_model(std::vector<float> dense, std::vector<uint16_t> indices, std::vector<float> values,
                             bool with_dense) {
  tinygltf::Model model;
  model.buffers.resize(1);
  auto& data = model.buffers[0].data;
  const auto add_view = [&](const void* bytes, size_t size) {
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = data.size();
    view.byteLength = size;
    data.insert(data.end(), static_cast<const unsigned char*>(bytes), static_cast<const unsigned char*>(bytes) + size);
    model.bufferViews.push_back(view);
    return static_cast<int>(model.bufferViews.size()) - 1;
  };
  tinygltf::Accessor accessor;
  accessor.type = TINYGLTF_TYPE_VEC3;
  accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  accessor.count = dense.size() / 3;
  if (with_dense) accessor.bufferView = add_view(dense.data(), dense.size() * sizeof(float));
  accessor.sparse.isSparse = true;
  accessor.sparse.count = static_cast<int>(indices.size());
  accessor.sparse.indices.bufferView = add_view(indices.data(), indices.size() * sizeof(uint16_t));
  accessor.sparse.indices.byteOffset = 0;
  accessor.sparse.indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
  accessor.sparse.values.bufferView = add_view(values.data(), values.size() * sizeof(float));
  accessor.sparse.values.byteOffset = 0;
  model.accessors.push_back(accessor);
  return model;
}

TEST(HostileGltf, SparseAccessorsAreReadAndTheirIndicesChecked) {
  const std::vector<float> dense = {0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3};
  const auto read = [](const tinygltf::Model& m) {
    return gltf::read_accessor(m, 0, TINYGLTF_TYPE_VEC3, "sparse.gltf", "POSITION");
  };
  EXPECT_EQ(read(sparse_model(dense, {1, 3}, {7, 8, 9, 4, 5, 6}, true)),
            (std::vector<double>{0, 0, 0, 7, 8, 9, 2, 2, 2, 4, 5, 6}));
  EXPECT_EQ(read(sparse_model(dense, {2}, {7, 8, 9}, false)),
            (std::vector<double>{0, 0, 0, 0, 0, 0, 7, 8, 9, 0, 0, 0}));  // zeros where no buffer view backs it
  testing::expect_error([&] { read(sparse_model(dense, {3, 1}, {7, 8, 9, 4, 5, 6}, true)); },
                        {"sparse.gltf", "strictly increasing"});
  testing::expect_error([&] { read(sparse_model(dense, {4}, {7, 8, 9}, true)); }, {"sparse.gltf", "below 4"});
  auto short_values = sparse_model(dense, {1, 3}, {7, 8, 9}, true);
  short_values.accessors[0].sparse.count = 2;
  testing::expect_error([&] { read(short_values); }, {"sparse values read past the end"});
  auto far = sparse_model(dense, {1}, {7, 8, 9}, true);
  far.accessors[0].sparse.values.byteOffset = 1 << 30;
  testing::expect_error([&] { read(far); }, {"sparse.gltf"});
}

// ---- assimp -----------------------------------------------------------------

const std::string kAssimpModels = "/usr/share/assimp/models/";

TEST(HostileAssimp, FilesAssimpCrashesOnAreRefusedNamingThem) {
  for (const char* file : {"RAW/WithColor.raw", "RAW/WithTexture.raw"}) {
    const auto path = kAssimpModels + file;
    ASSERT_TRUE(fs::exists(path)) << path << " (scripts/setup.sh installs assimp-testmodels)";
    testing::expect_error([&] { import_with_assimp(path); }, {path});
  }
}

TEST(HostileAssimp, AReaderThatAllocatesWithoutEndIsStoppedByItsBudget) {
  const auto path = kAssimpModels + "invalid/OutOfMemory.off";
  ASSERT_TRUE(fs::exists(path)) << path;
  ImportOptions options;
  options.assimp_memory_mib = 256;
  options.assimp_seconds = 60;
  testing::expect_error([&] { import_with_assimp(path, options); }, {path});
  // A time budget alone stops it too (sanitizer builds lift the memory limit).
  options.assimp_memory_mib = 1 << 20;
  options.assimp_seconds = 2;
  testing::expect_error([&] { import_with_assimp(path, options); }, {path});
}

// Every file of Debian's assimp-testmodels (models of every format assimp
// reads, valid and invalid) through `fskin import`: each imports or is
// refused with an fskin::Error naming it; none crashes, hangs or escapes as
// another exception.
TEST(HostileAssimp, EveryTestModelImportsOrIsRefusedNamingIt) {
  ASSERT_TRUE(fs::exists(kAssimpModels)) << kAssimpModels << " (scripts/setup.sh installs assimp-testmodels)";
  std::vector<std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(kAssimpModels))
    if (entry.is_regular_file()) files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  ImportOptions options;
  options.assimp_seconds = 30;
  options.assimp_memory_mib = 1024;
  int imported = 0, refused = 0;
  for (const auto& file : files) {
    try {
      import_character(file, options);
      ++imported;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << file << ": not an fskin::Error: " << e.what();
    }
  }
  std::printf("assimp-testmodels: %zu files, %d imported, %d refused\n", files.size(), imported, refused);
  EXPECT_GT(imported, 5);  // the rigged ones (FBX, Collada, glTF, X, MD5, ...) import
}

TEST(HostileAssimp, AFileThatIsNotRegularIsRefused) {
  const auto dir = testing::temp_dir("hostile_assimp_dir") / "rig.fbx";
  fs::create_directories(dir);
  testing::expect_error([&] { import_with_assimp(dir.string()); }, {"rig.fbx", "not a regular file"});
}

// ---- BVH and AMASS ------------------------------------------------------------

const BodyModel& human() {
  static const BodyModel* model = [] {
    CharacterOptions o;
    o.resolution = 40;
    return new BodyModel(make_character_model(o));
  }();
  return *model;
}

std::string bvh_text(const std::string& hierarchy_extra, int frames, const std::string& motion) {
  return "HIERARCHY\nROOT pelvis\n{\n  OFFSET 0 90 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
         "Yrotation\n  JOINT left_hip\n  {\n    OFFSET 8 -5 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End "
         "Site\n    {\n      OFFSET 0 -40 0\n    }\n  }\n" +
         hierarchy_extra + "}\nMOTION\nFrames: " + std::to_string(frames) + "\nFrame Time: 0.033333\n" + motion;
}

std::string write_bvh(const std::string& text, const std::string& name) {
  const auto path = (testing::temp_dir("hostile_bvh") / (name + ".bvh")).string();
  spit(path, text);
  return path;
}

TEST(HostileBvh, AWellFormedFileImports) {
  const auto motion = import_bvh(write_bvh(bvh_text("", 2, "0 0 0 0 0 0 10 0 0\n1 0 0 0 5 0 0 0 0\n"), "good"),
                                 human().skeleton());
  EXPECT_EQ(motion.poses.poses.size(0), 2);
}

TEST(HostileBvh, ADeepHierarchyIsRefusedWithoutRecursion) {
  std::string deep = "HIERARCHY\nROOT pelvis\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n";
  constexpr int kDepth = 100'000;
  for (int i = 0; i < kDepth; ++i) deep += "JOINT j" + std::to_string(i) + "\n{\nOFFSET 0 1 0\nCHANNELS 0\n";
  for (int i = 0; i <= kDepth; ++i) deep += "}\n";
  deep += "MOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0\n";
  testing::expect_error([&] { import_bvh(write_bvh(deep, "deep"), human().skeleton()); },
                        {"deep.bvh", "more than 10000 joints"});
}

TEST(HostileBvh, AFrameCountTheFileCannotHoldIsRefusedBeforeAllocating) {
  for (const char* frames : {"2000000", "1000000000", "1e19", "1e300"}) {
    std::string text = bvh_text("", 1, "0 0 0 0 0 0 0 0 0\n");
    text.replace(text.find("Frames: 1"), 9, std::string("Frames: ") + frames);
    testing::expect_error([&] { import_bvh(write_bvh(text, "frames"), human().skeleton()); }, {"frames.bvh"});
  }
}

TEST(HostileBvh, AFileCutAfterTheFrameTimeIsRefused) {
  std::string text = bvh_text("", 1, "");
  text.resize(text.size() - 5);  // "Frame Time: 0.03", no newline, no motion
  testing::expect_error([&] { import_bvh(write_bvh(text, "cut"), human().skeleton()); }, {"cut.bvh"});
}

TEST(HostileBvh, MotionLinesMustMatchTheChannelsAndTheFrameCount) {
  const auto& skeleton = human().skeleton();
  testing::expect_error(
      [&] { import_bvh(write_bvh(bvh_text("", 2, "0 0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n"), "more"), skeleton); },
      {"more.bvh:", "frame 0 has more than the hierarchy's 9 channel values"});
  testing::expect_error(
      [&] { import_bvh(write_bvh(bvh_text("", 2, "0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n"), "fewer"), skeleton); },
      {"fewer.bvh:", "frame 0 has 8 values for the hierarchy's 9 channels"});
  testing::expect_error(
      [&] {
        import_bvh(write_bvh(bvh_text("", 1, "0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n"), "extra"), skeleton);
      },
      {"extra.bvh:", "beyond the 1 frames"});
  testing::expect_error([&] { import_bvh(write_bvh(bvh_text("", 3, "0 0 0 0 0 0 0 0 0\n"), "missing"), skeleton); },
                        {"missing.bvh", "'Frames: 3'"});
  // Padded so the byte count passes: the line count is what refuses it.
  testing::expect_error(
      [&] {
        import_bvh(write_bvh(bvh_text("", 2, "0 0 0 0 0 0 0 0 0\n" + std::string(200, ' ')), "padded"), skeleton);
      },
      {"padded.bvh", "'Frames: 2' but the file holds 1 motion lines"});
}

TEST(HostileBvh, ImplausibleValuesAndDuplicateNamesAreRefused) {
  const auto& skeleton = human().skeleton();
  testing::expect_error(
      [&] { import_bvh(write_bvh(bvh_text("", 1, "0 0 0 0 0 0 1e300 0 0\n"), "spin"), skeleton); },
      {"spin.bvh", "left_hip", "Zrotation", "degrees"});
  testing::expect_error(
      [&] { import_bvh(write_bvh(bvh_text("", 1, "1e30 0 0 0 0 0 0 0 0\n"), "far"), skeleton); },
      {"far.bvh", "Xposition", "skeleton sizes"});
  const std::string twin = "  JOINT left_hip\n  {\n    OFFSET -8 -5 0\n    CHANNELS 0\n  }\n";
  testing::expect_error(
      [&] { import_bvh(write_bvh(bvh_text(twin, 1, "0 0 0 0 0 0 0 0 0\n"), "twin"), skeleton); },
      {"twin.bvh", "two joints are named 'left_hip'"});
}

TEST(HostileAmass, HugePosesAndTranslationsAreRefused) {
  const auto& model = human();
  const int64_t J = model.num_joints();
  const auto dir = testing::temp_dir("hostile_amass");
  {
    io::NpzWriter npz;
    auto poses = torch::zeros({2, 3 * J});
    poses[1][4] = 1e30;
    npz.add("poses", poses);
    npz.save((dir / "spin.npz").string());
    testing::expect_error([&] { import_amass((dir / "spin.npz").string(), model.skeleton()); },
                          {"spin.npz", "100 turns"});
  }
  {
    io::NpzWriter npz;
    npz.add("poses", torch::zeros({2, 3 * J}));
    npz.add("trans", torch::full({2, 3}, 1e30));
    npz.save((dir / "far.npz").string());
    testing::expect_error([&] { import_amass((dir / "far.npz").string(), model.skeleton()); },
                          {"far.npz", "'trans'", "skeleton size"});
  }
}

// ---- run directories and output paths -------------------------------------------

TEST(RunLock, ASecondWriterFailsAtOnceNamingTheHolder) {
  const auto dir = (testing::temp_dir("run_lock") / "run").string();
  {
    const RunLock first(dir);
    testing::expect_error([&] { RunLock second(dir); },
                          {dir, "another fskin process", "PID " + std::to_string(::getpid())});
  }
  const RunLock again(dir);  // released when the holder ends
  SUCCEED();
}

TEST(RunLock, ALogKeepsEachStepOnceAfterResume) {
  const auto dir = testing::temp_dir("run_log");
  const auto log = (dir / "log.jsonl").string();
  spit(log, "{\"step\": 1}\n{\"step\": 2}\n{\"step\": 3}\n{\"step\": 4, \"lo");
  keep_log_through_step(log, 2);
  EXPECT_EQ(read_file(log), "{\"step\": 1}\n{\"step\": 2}\n");
}

TEST(OutputPaths, DirectoriesThatCannotBeCreatedAreErrorsNamingThePath) {
  const auto dir = testing::temp_dir("output_paths");
  spit(dir / "file", "x");
  const auto under_file = (dir / "file" / "run").string();
  testing::expect_error([&] { create_output_directory(under_file); }, {under_file, "cannot create"});
  testing::expect_error([&] { RunLock lock(under_file); }, {under_file});
  testing::expect_error([&] { write_file_atomically(under_file + "/x.json", "{}"); }, {under_file});
  if (::geteuid() != 0) {  // root writes anywhere
    fs::create_directories(dir / "read_only");
    fs::permissions(dir / "read_only", fs::perms::owner_read | fs::perms::owner_exec);
    const auto inside = (dir / "read_only" / "run").string();
    testing::expect_error([&] { create_output_directory(inside); }, {inside, "cannot create"});
    fs::permissions(dir / "read_only", fs::perms::owner_all);
  }
}

TEST(OutputPaths, AnOutputMayNotOverlapItsInput) {
  const auto dir = testing::temp_dir("overlap");
  const auto data = (dir / "data").string();
  fs::create_directories(data);
  testing::expect_error([&] { check_output_apart_from_input(data, data, "avatar train"); },
                        {"avatar train", "is the input"});
  testing::expect_error([&] { check_output_apart_from_input(data + "/run", data, "train"); }, {"lies inside"});
  testing::expect_error([&] { check_output_apart_from_input(dir.string(), data, "train"); }, {"holds"});
  check_output_apart_from_input((dir / "data_run").string(), data, "train");  // a sibling whose name extends it
}

TEST(OutputPaths, PicturesAreWrittenOnlyUnderAPngName) {
  const auto dir = testing::temp_dir("png_names");
  testing::expect_error([&] { write_png((dir / "x.jpg").string(), Image(4, 4)); }, {"x.jpg", "name the file .png"});
  write_png((dir / "x.PNG").string(), Image(4, 4));
  EXPECT_TRUE(fs::exists(dir / "x.PNG"));
}

// ---- values that are read as numbers -------------------------------------------------

TEST(HostileValues, LearningRatesFramesPerSecondAndDivergedImagesAreRefused) {
  TrainConfig config;
  config.learning_rate = 1e30;
  testing::expect_error([&] { config.validate(); }, {"learning_rate", "(0, 1]"});
  SkinnedCharacter rig = testing::skinned(testing::small_model(false), 2);
  rig.fps = 1e-300;
  const auto path = (testing::temp_dir("hostile_fps") / "a.glb").string();
  testing::expect_error([&] { write_skinned_gltf(path, rig); }, {"fps", "not a frame rate"});
  const auto nan = torch::full({4, 4, 3}, std::nanf(""));
  testing::expect_error([&] { psnr(nan, torch::zeros({4, 4, 3})); }, {"non-finite"});
}

// ---- image datasets ------------------------------------------------------------

// A copy of the tiny dataset with `edit` applied to it.
std::string damaged_copy(const std::string& name, const std::function<void(const fs::path&)>& edit) {
  const auto dir = testing::temp_dir("hostile_images") / name;
  fs::remove_all(dir);
  fs::copy(testing::tiny_image_dataset().dir, dir, fs::copy_options::recursive);
  edit(dir);
  return dir.string();
}

void edit_cameras(const fs::path& dir, const std::function<void(torch::Tensor&, torch::Tensor&)>& edit) {
  const auto path = (dir / "train" / "cameras.npz").string();
  const io::NpzReader in(path);
  auto intrinsic = in.tensor("intrinsic").clone(), extrinsic = in.tensor("extrinsic").clone();
  edit(intrinsic, extrinsic);
  io::NpzWriter out;
  out.add("intrinsic", intrinsic);
  out.add("extrinsic", extrinsic);
  out.add("height", in.tensor("height"));
  out.add("width", in.tensor("width"));
  out.save(path);
}

TEST(HostileImageDataset, TheUntouchedCopyLoads) {
  const ImageDataset data(damaged_copy("untouched", [](const fs::path&) {}));
  EXPECT_GT(data.load_split("train").size(), 0);
}

TEST(HostileImageDataset, ABackgroundOutsideZeroToOneIsRefused) {
  const auto dir = damaged_copy("background", [](const fs::path& d) {
    auto manifest = json::parse(read_file((d / "manifest.json").string()));
    manifest["background"] = {-5, 1e9, 0.5};
    spit(d / "manifest.json", manifest.dump());
  });
  testing::expect_error([&] { ImageDataset data(dir); }, {"manifest.json", "background", "[0, 1]"});
}

TEST(HostileImageDataset, AManifestWithoutARequiredFieldNamesIt) {
  for (const char* field : {"format", "background", "splits"}) {
    const auto dir = damaged_copy(std::string("no_") + field, [&](const fs::path& d) {
      auto manifest = json::parse(read_file((d / "manifest.json").string()));
      manifest.erase(field);
      spit(d / "manifest.json", manifest.dump());
    });
    testing::expect_error([&] { ImageDataset data(dir); },
                          {"manifest.json", std::string("no \"") + field + "\" field", "needs format, background and splits"});
  }
}

TEST(HostileImageDataset, FocalLengthsBeyondALensAreRefused) {
  const auto dir = damaged_copy("focal", [](const fs::path& d) {
    edit_cameras(d, [](torch::Tensor& k, torch::Tensor&) { k.select(-2, 0).select(-1, 0).fill_(1e300); });
  });
  const ImageDataset data(dir);
  testing::expect_error([&] { data.load_split("train"); }, {"cameras.npz", "focal"});
}

TEST(HostileImageDataset, ACameraWithTheSubjectBehindItIsRefused) {
  const auto dir = damaged_copy("behind", [](const fs::path& d) {
    // Turned half a turn about its own y axis: the subject is behind it.
    edit_cameras(d, [](torch::Tensor&, torch::Tensor& e) {
      const auto flip = torch::diag(torch::tensor({-1.0, 1.0, -1.0, 1.0}, e.options()));
      e = torch::matmul(flip, e);
    });
  });
  const ImageDataset data(dir);
  testing::expect_error([&] { data.load_split("train"); }, {"cameras.npz", "behind it"});
}

TEST(HostileImageDataset, AllEmptyMasksAreRefused) {
  const auto dir = damaged_copy("empty_masks", [](const fs::path& d) {
    for (const auto& entry : fs::directory_iterator(d / "train" / "masks")) {
      int width = 0, height = 0;
      auto gray = read_png_gray(entry.path().string(), width, height);
      std::fill(gray.begin(), gray.end(), 0);
      write_png_gray(entry.path().string(), width, height, gray);
    }
  });
  const ImageDataset data(dir);
  testing::expect_error([&] { data.load_split("train"); }, {"masks", "all", "empty"});
}

}  // namespace
}  // namespace fskin
