// Every file fskin reads, mutated: seeded byte mutations (bit flips, special
// bytes, truncation, insertion, deleted and repeated chunks) and structure
// mutations (an .npz member re-typed, re-shaped, emptied, filled with NaN,
// infinities, huge values or out-of-range indices, removed or added; a JSON
// value deleted or given another type or an extreme number; a text line
// deleted, repeated or with a token replaced). Each case must be accepted or
// rejected with fskin::Error: any other exception is an "internal error" in
// the CLI, and a crash or a hang fails the test binary.
//
// FSKIN_FUZZ_CASES (per target, default 250) and FSKIN_FUZZ_SEED (default 1)
// set the size and seed; FSKIN_FUZZ_VERBOSE=1 prints each case to stderr
// before running it, to find the one that crashes.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <zlib.h>

#include "fskin/body/character.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset.h"
#include "fskin/data/dataset_builder.h"
#include "fskin/data/dataset_frame.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/pose_generators.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/import/gltf_import.h"
#include "fskin/import/motion_import.h"
#include "fskin/io/mesh_io.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/training/train_config.h"
#include "fskin/util/atomic_file.h"
#include "radiance/tiny_image_dataset.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;
using Random = std::mt19937_64;

int64_t env_int(const char* name, int64_t fallback) {
  const char* value = std::getenv(name);
  return value && *value ? std::atoll(value) : fallback;
}

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void spit(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

size_t below(Random& rng, size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<size_t>(0, n - 1)(rng); }

// ---- byte mutations ---------------------------------------------------------

std::string mutate_bytes(std::string bytes, Random& rng, std::string& what) {
  if (bytes.empty()) return "x";
  const size_t at = below(rng, bytes.size());
  switch (below(rng, 6)) {
    case 0: {
      const size_t flips = 1 + below(rng, 8);
      for (size_t i = 0; i < flips; ++i) bytes[below(rng, bytes.size())] ^= static_cast<char>(1 << below(rng, 8));
      what = fmt::format("{} bit flips", flips);
      break;
    }
    case 1: {
      static const unsigned char special[] = {0x00, 0xff, 0x7f, 0x80, 0x01, 0xfe};
      const size_t n = 1 + below(rng, 4);
      for (size_t i = 0; i < n && at + i < bytes.size(); ++i) bytes[at + i] = static_cast<char>(special[below(rng, 6)]);
      what = fmt::format("special bytes at {}", at);
      break;
    }
    case 2:
      bytes.resize(at);
      what = fmt::format("truncated to {}", at);
      break;
    case 3: {
      std::string junk(1 + below(rng, 16), '\0');
      for (auto& c : junk) c = static_cast<char>(below(rng, 256));
      bytes.insert(at, junk);
      what = fmt::format("{} bytes inserted at {}", junk.size(), at);
      break;
    }
    case 4: {
      const size_t n = std::min(bytes.size() - at, 1 + below(rng, 64));
      bytes.erase(at, n);
      what = fmt::format("{} bytes deleted at {}", n, at);
      break;
    }
    default: {
      const size_t n = std::min(bytes.size() - at, 1 + below(rng, 64));
      bytes.insert(at, bytes.substr(at, n));
      what = fmt::format("{} bytes repeated at {}", n, at);
      break;
    }
  }
  return bytes;
}

// ---- .npz structure mutations ----------------------------------------------

struct Member {
  bool is_strings = false;
  torch::Tensor tensor;
  std::vector<std::string> strings;
};

std::map<std::string, Member> read_members(const std::string& path) {
  io::NpzReader npz(path);
  std::map<std::string, Member> members;
  for (const auto& key : npz.keys()) {
    Member m;
    try {
      m.tensor = npz.tensor(key);
    } catch (const Error&) {
      m.is_strings = true;
      m.strings = npz.strings(key);
    }
    members[key] = m;
  }
  return members;
}

torch::Tensor mutate_tensor(torch::Tensor t, Random& rng, std::string& what) {
  t = t.clone();
  switch (below(rng, 11)) {
    case 0: what = "as float64"; return t.to(torch::kFloat64);
    case 1: what = "as int32"; return t.to(torch::kInt32);
    case 2: what = "as uint8"; return t.to(torch::kUInt8);
    case 3: what = "as bool"; return t.to(torch::kBool);
    case 4: what = "flattened"; return t.flatten().contiguous();
    case 5: what = "extra dimension"; return t.unsqueeze(0).contiguous();
    case 6:
      what = "one row fewer";
      return t.dim() > 0 && t.size(0) > 0 ? t.narrow(0, 0, t.size(0) - 1).contiguous() : t;
    case 7: what = "empty"; return t.dim() > 0 ? t.narrow(0, 0, 0).contiguous() : torch::empty({0}, t.options());
    case 8:
      what = "last two dimensions swapped";
      return t.dim() >= 2 ? t.transpose(-1, -2).contiguous() : t;
    default: {
      if (t.numel() == 0) return t;
      const auto flat = t.view({-1});
      const int64_t i = static_cast<int64_t>(below(rng, static_cast<size_t>(t.numel())));
      if (t.is_floating_point()) {
        static const double values[] = {std::nan(""), INFINITY, -INFINITY, 1e30, -1e30, 0.0, 255.0, -1.0};
        const double v = values[below(rng, 8)];
        flat[i] = v;
        what = fmt::format("element {} = {}", i, v);
      } else if (t.scalar_type() == torch::kBool) {
        flat[i] = !flat[i].item<bool>();
        what = fmt::format("element {} negated", i);
      } else {
        static const int64_t values[] = {-1, -2, 99, 255, 1 << 20, 2147483647, -2147483647};
        int64_t v = values[below(rng, 7)];
        if (t.scalar_type() == torch::kUInt8) v &= 0xff;
        if (t.scalar_type() == torch::kInt8 || t.scalar_type() == torch::kInt16) v = std::max<int64_t>(-100, std::min<int64_t>(v, 100));
        flat[i] = v;
        what = fmt::format("element {} = {}", i, v);
      }
      return t;
    }
  }
}

std::string mutate_npz(const fs::path& seed, const fs::path& out, Random& rng, std::string& what) {
  auto members = read_members(seed.string());
  auto it = members.begin();
  std::advance(it, static_cast<long>(below(rng, members.size())));
  const std::string key = it->first;
  const size_t op = below(rng, 10);
  if (op == 0) {
    members.erase(it);
    what = "member '" + key + "' removed";
  } else if (op == 1) {
    Member extra;
    extra.tensor = torch::randn({3, 2});
    members["unexpected_" + key] = extra;
    what = "member 'unexpected_" + key + "' added";
  } else if (it->second.is_strings) {
    auto& s = it->second.strings;
    switch (below(rng, 4)) {
      case 0: if (!s.empty()) s.pop_back(); what = "'" + key + "' one string fewer"; break;
      case 1: s.push_back(s.empty() ? "" : s.front()); what = "'" + key + "' first string repeated"; break;
      case 2: if (!s.empty()) s[below(rng, s.size())] = ""; what = "'" + key + "' an empty string"; break;
      default:
        it->second.is_strings = false;
        it->second.tensor = torch::zeros({static_cast<int64_t>(s.size())});
        what = "'" + key + "' numbers instead of strings";
    }
  } else {
    std::string how;
    it->second.tensor = mutate_tensor(it->second.tensor, rng, how);
    what = "'" + key + "' " + how;
  }
  io::NpzWriter writer;
  for (const auto& [k, m] : members) {
    if (m.is_strings) writer.add_strings(k, m.strings);
    else writer.add(k, m.tensor.contiguous());
  }
  writer.save(out.string(), below(rng, 2) == 0);
  return slurp(out);
}

// ---- JSON structure mutations -----------------------------------------------

void collect_paths(const nlohmann::json& j, const nlohmann::json::json_pointer& at,
                   std::vector<nlohmann::json::json_pointer>& out) {
  out.push_back(at);
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it) collect_paths(it.value(), at / it.key(), out);
  if (j.is_array())
    for (size_t i = 0; i < j.size() && i < 64; ++i) collect_paths(j[i], at / i, out);
}

std::string mutate_json(const std::string& text, Random& rng, std::string& what) {
  auto j = nlohmann::json::parse(text);
  std::vector<nlohmann::json::json_pointer> paths;
  collect_paths(j, nlohmann::json::json_pointer(), paths);
  const auto path = paths[1 + below(rng, paths.size() - 1)];
  auto& value = j[path];
  static const std::vector<nlohmann::json> replacements = {
      nullptr, true, -1, 0, 1e308, -1e308, 2147483648.0, "text", "", nlohmann::json::array(), nlohmann::json::object(),
      nlohmann::json::array({1, 2, 3}), nlohmann::json::array({"a", "b"}), 1e-300, 99999999};
  switch (below(rng, 4)) {
    case 0: {
      const auto parent = path.parent_pointer();
      auto& container = j[parent];
      if (container.is_object()) container.erase(path.back());
      else if (container.is_array()) container.erase(container.begin() + static_cast<long>(std::stoul(path.back())));
      what = "deleted " + path.to_string();
      break;
    }
    case 1:
      if (value.is_array() && !value.empty()) {
        value.erase(value.end() - 1);
        what = "one element fewer at " + path.to_string();
        break;
      }
      [[fallthrough]];
    case 2:
      if (value.is_array()) {
        value.push_back(value.empty() ? nlohmann::json(0) : value.front());
        what = "one element more at " + path.to_string();
        break;
      }
      [[fallthrough]];
    default: {
      const auto& r = replacements[below(rng, replacements.size())];
      value = r;
      what = path.to_string() + " = " + r.dump();
    }
  }
  return j.dump(below(rng, 2) ? 2 : -1);
}

// ---- text line mutations ----------------------------------------------------

std::string mutate_lines(const std::string& text, Random& rng, std::string& what) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  if (lines.empty()) return text;
  const size_t at = below(rng, lines.size());
  switch (below(rng, 3)) {
    case 0: lines.erase(lines.begin() + static_cast<long>(at)); what = fmt::format("line {} deleted", at); break;
    case 1: lines.insert(lines.begin() + static_cast<long>(at), lines[at]); what = fmt::format("line {} repeated", at); break;
    default: {
      static const char* tokens[] = {"nan", "inf", "-1", "1e40", "abc", "99999999", "0", "-2147483649", "", "4294967296"};
      std::istringstream words(lines[at]);
      std::vector<std::string> w;
      for (std::string s; words >> s;) w.push_back(s);
      if (w.empty()) break;
      const char* token = tokens[below(rng, 10)];
      w[below(rng, w.size())] = token;
      std::string joined;
      for (const auto& s : w) joined += (joined.empty() ? "" : " ") + s;
      lines[at] = joined;
      what = fmt::format("line {} token = '{}'", at, token);
    }
  }
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

// ---- glTF structure mutations --------------------------------------------------

// What breaks glTF readers: offsets near 2^64, counts beyond the buffer,
// strides, missing indices, sparse accessors, node depth and cycles, skins
// and animation samplers pointing anywhere, non-unit or non-finite
// transforms.
std::string mutate_gltf(const std::string& text, Random& rng, std::string& what) {
  auto g = nlohmann::json::parse(text);
  const auto pick = [&](const char* array) -> nlohmann::json* {
    auto& items = g[array];
    return items.is_array() && !items.empty() ? &items[below(rng, items.size())] : nullptr;
  };
  static const std::vector<nlohmann::json> huge = {
      ~uint64_t{0}, ~uint64_t{0} - 3, uint64_t{1} << 63, uint64_t{1} << 62, uint64_t{1} << 32, 4294967295u,
      2147483647, 2147483648u, -1, -2147483648LL, 0, 1, 3, 4, 5, 7};
  const auto& h = huge[below(rng, huge.size())];
  switch (below(rng, 12)) {
    case 0:
      if (auto* a = pick("accessors")) (*a)["byteOffset"] = h, what = "accessor byteOffset = " + h.dump();
      break;
    case 1:
      if (auto* a = pick("accessors")) (*a)["count"] = h, what = "accessor count = " + h.dump();
      break;
    case 2:
      if (auto* v = pick("bufferViews")) {
        static const char* fields[] = {"byteOffset", "byteLength", "byteStride", "buffer"};
        const char* field = fields[below(rng, 4)];
        (*v)[field] = h;
        what = fmt::format("bufferView {} = {}", field, h.dump());
      }
      break;
    case 3:
      for (auto& mesh : g["meshes"])
        for (auto& primitive : mesh["primitives"]) primitive.erase("indices");
      what = "every primitive without indices";
      break;
    case 4:
      if (auto* a = pick("accessors")) {
        const auto views = g["bufferViews"].size();
        (*a)["sparse"] = {{"count", huge[below(rng, huge.size())]},
                          {"indices", {{"bufferView", below(rng, views + 1)}, {"byteOffset", below(rng, 64)},
                                       {"componentType", below(rng, 2) ? 5123 : 5125}}},
                          {"values", {{"bufferView", below(rng, views + 1)}, {"byteOffset", below(rng, 64)}}}};
        if (below(rng, 2)) a->erase("bufferView");
        what = "sparse accessor " + (*a)["sparse"].dump();
      }
      break;
    case 5: {
      const size_t depth = 1 + below(rng, 20000);
      const size_t first = g["nodes"].size();
      for (size_t i = 0; i < depth; ++i)
        g["nodes"].push_back({{"name", "chain" + std::to_string(i)},
                              {"children", i + 1 < depth ? nlohmann::json::array({first + i + 1}) : g["scenes"][0]["nodes"]}});
      g["scenes"][0]["nodes"] = nlohmann::json::array({first});
      what = fmt::format("the scene under a {}-deep node chain", depth);
      break;
    }
    case 6:
      if (auto* n = pick("nodes")) {
        const auto index = g["nodes"].size() > 0 ? below(rng, g["nodes"].size()) : 0;
        (*n)["children"].push_back(index);
        what = fmt::format("node gets child {} (a cycle or a second parent)", index);
      }
      break;
    case 7:
      if (auto* skin = pick("skins")) {
        auto& joints = (*skin)["joints"];
        if (!joints.empty()) joints[below(rng, joints.size())] = h;
        what = "a skin joint = " + h.dump();
      }
      break;
    case 8:
      if (auto* animation = pick("animations")) {
        auto& samplers = (*animation)["samplers"];
        if (!samplers.empty()) {
          auto& sampler = samplers[below(rng, samplers.size())];
          static const char* interpolations[] = {"CUBICSPLINE", "STEP", "LINEAR", "SPLINE"};
          if (below(rng, 2)) sampler["interpolation"] = interpolations[below(rng, 4)];
          else std::swap(sampler["input"], sampler["output"]);
          what = "animation sampler " + sampler.dump();
        }
      }
      break;
    case 9:
      if (auto* n = pick("nodes")) {
        static const std::vector<nlohmann::json> rotations = {
            {0, 0, 0, 0}, {0, 0, 0, 1e30}, {1e-30, 0, 0, 0}, {0, 0, 0, 1, 1}, {0, 0, 0}};
        (*n)["rotation"] = rotations[below(rng, rotations.size())];
        what = "node rotation " + (*n)["rotation"].dump();
      }
      break;
    case 10:
      if (auto* n = pick("nodes")) {
        (*n)["translation"] = {1e30, 0, 0};
        if (below(rng, 2)) (*n)["scale"] = {0, 0, 0};
        what = "node translation 1e30 " + n->dump().substr(0, 80);
      }
      break;
    default:
      if (auto* a = pick("accessors")) {
        static const int types[] = {5120, 5121, 5122, 5123, 5125, 5126, 0, 5124, 99999};
        (*a)["componentType"] = types[below(rng, 9)];
        if (below(rng, 2)) (*a)["normalized"] = true;
        what = "accessor componentType " + (*a)["componentType"].dump();
      }
  }
  if (what.empty()) what = "unchanged";
  return g.dump();
}

// ---- BVH structure mutations ----------------------------------------------------

// What breaks BVH readers: deep hierarchies, frame counts the file cannot
// hold, motion lines with more or fewer values, huge values, twin names.
std::string mutate_bvh(const std::string& text, Random& rng, std::string& what) {
  std::string out = text;
  const auto replace_after = [&](const std::string& key, const std::string& value) {
    const auto at = out.find(key);
    if (at == std::string::npos) return;
    const auto end = out.find('\n', at);
    out.replace(at + key.size(), end - at - key.size(), value);
  };
  switch (below(rng, 6)) {
    case 0: {
      static const char* frames[] = {" 0", " -1", " 1e9", " 1e19", " 1e300", " 2000000", " 2.5", " 99"};
      const char* f = frames[below(rng, 8)];
      replace_after("Frames:", f);
      what = std::string("Frames:") + f;
      break;
    }
    case 1: {
      const size_t depth = 1 + below(rng, 30000);
      std::string chain;
      for (size_t i = 0; i < depth; ++i) chain += "JOINT deep" + std::to_string(i) + "\n{\nOFFSET 0 1 0\nCHANNELS 0\n";
      for (size_t i = 0; i < depth; ++i) chain += "}\n";
      const auto at = out.find("JOINT");
      out.insert(at, chain);
      what = fmt::format("a {}-deep joint chain", depth);
      break;
    }
    case 2: {
      const auto motion = out.find("Frame Time:");
      const auto line = out.find('\n', motion) + 1;
      out.insert(line, below(rng, 2) ? "0 " : "");
      if (below(rng, 2)) out.insert(out.find('\n', line), " 0 0");
      what = "a motion line with another number of values";
      break;
    }
    case 3: {
      static const char* values[] = {"1e300", "-1e300", "1e30", "36001", "nan", "inf"};
      const auto motion = out.find("Frame Time:");
      const auto line = out.find('\n', motion) + 1;
      const char* v = values[below(rng, 6)];
      out.replace(line, out.find(' ', line) - line, v);
      what = std::string("first motion value = ") + v;
      break;
    }
    case 4: {
      const auto motion = out.find("Frame Time:");
      const auto line = out.find('\n', motion) + 1;
      const std::string first = out.substr(line, out.find('\n', line) - line + 1);
      for (size_t i = 0, n = 1 + below(rng, 3); i < n; ++i) out += first;
      what = "motion lines beyond Frames:";
      break;
    }
    default: {
      const auto second = out.find("JOINT", out.find("JOINT") + 5);
      if (second != std::string::npos) {
        const auto name_end = out.find('\n', second);
        out.replace(second + 6, name_end - second - 6, "pelvis");
      }
      what = "a joint named like the root";
    }
  }
  return out;
}

// ---- checkpoints ------------------------------------------------------------

// A checkpoint whose payload is mutated and whose header (size, CRC-32) is
// made valid again: damage the CRC cannot see (checkpoint.h's layout: magic
// [8], payload size u64, CRC-32 u32, payload).
std::string mutate_sealed_checkpoint(const std::string& bytes, Random& rng, std::string& what) {
  constexpr size_t kHeader = 8 + 8 + 4;
  if (bytes.size() <= kHeader) return bytes;
  const std::string payload = mutate_bytes(bytes.substr(kHeader), rng, what);
  what = "sealed payload, " + what;
  const uint64_t size = payload.size();
  const uint32_t crc = static_cast<uint32_t>(
      ::crc32(0L, reinterpret_cast<const Bytef*>(payload.data()), static_cast<uInt>(payload.size())));
  std::string out = bytes.substr(0, 8);
  out.append(reinterpret_cast<const char*>(&size), sizeof size);
  out.append(reinterpret_cast<const char*>(&crc), sizeof crc);
  return out + payload;
}

// ---- targets ----------------------------------------------------------------

enum class Kind { Npz, Json, Text, Binary, Gltf, Bvh, Checkpoint };

struct Target {
  std::string name;
  fs::path seed;   // a valid file
  fs::path path;   // where the mutated file goes (the reader's input)
  Kind kind;
  std::function<void()> read;
};

struct Fixture {
  fs::path dir;
  std::vector<Target> targets;
  const Target* find(const std::string& name) const {
    for (const auto& t : targets)
      if (t.name == name) return &t;
    return nullptr;
  }
};

// Meshes, models, poses, configs, imports and (with Embree) a scan dataset.
const Fixture& scan_fixture() {
  static const Fixture f = [] {
    Fixture f;
    f.dir = testing::temp_dir("input_fuzz");
    const auto seeds = f.dir / "seeds";
    fs::create_directories(seeds);
    CharacterOptions character;
    character.resolution = 32;
    const auto model = make_character_model(character);
    const auto names = model.data().joint_names;
    const int64_t J = model.num_joints();
    model.save((seeds / "model.npz").string());
    auto poses = make_training_poses(names, {1, 4, 2});
    poses.trans = torch::randn({4, 3}) * 0.1;
    poses.save((seeds / "poses.npz").string());
    io::write_mesh((seeds / "mesh.ply").string(), model.template_mesh());
    io::write_mesh((seeds / "mesh.obj").string(), model.template_mesh());
    spit(seeds / "ascii.ply",
         "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 4\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
         "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
    write_file_atomically((seeds / "config.json").string(), TrainConfig{}.to_json());
    SkinnedCharacter rig;
    rig.mesh = model.template_mesh();
    rig.weights = model.data().weights;
    rig.skeleton = model.skeleton();
    rig.animation = poses;
    write_skinned_gltf((seeds / "rig.glb").string(), rig);
    write_skinned_gltf((seeds / "rig.gltf").string(), rig);

    spit(seeds / "walk.bvh", R"(HIERARCHY
ROOT pelvis
{
  OFFSET 0 90 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT left_hip
  {
    OFFSET 8 -5 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT left_knee
    {
      OFFSET 0 -40 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 -40 0
      }
    }
  }
  JOINT spine1
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
  }
}
MOTION
Frames: 3
Frame Time: 0.0333333
0 90 0  0 0 0  0 0 0  0 0 0  0 0 0
1 91 2  10 0 5  20 0 0  0 45 0  5 5 5
2 92 4  20 0 10  40 0 0  0 90 0  10 10 10
)");
    {
      io::NpzWriter amass;
      amass.add("poses", (torch::randn({5, 3 * J}) * 0.2).contiguous());
      amass.add("trans", torch::randn({5, 3}).contiguous());
      amass.add("mocap_framerate", torch::tensor({60.0}));
      amass.save((seeds / "amass.npz").string());
    }
    const auto data = f.dir / "data";
    const bool have_dataset = inside_test_available();
    if (have_dataset) {
      DatasetBuildOptions options;
      options.out_dir = data.string();
      options.model_source = (seeds / "model.npz").string();
      options.sampling.uniform_points = 64;
      options.sampling.surface_points = 64;
      options.val_fraction = 0.25;
      options.test_fraction = 0.25;
      options.progress = false;
      build_dataset(model, poses, PoseSet{}, options);
      fs::copy_file(data / "manifest.json", seeds / "manifest.json");
      for (const auto& entry : fs::directory_iterator(data))
        if (entry.path().extension() == ".npz" && entry.path().filename() != "canonical.npz") {
          fs::copy_file(entry.path(), seeds / "frame.npz");
          break;
        }
    }
    const auto in = [&](const std::string& name) { return f.dir / ("case_" + name); };
    f.targets.push_back({"model", seeds / "model.npz", in("model.npz"), Kind::Npz, [p = in("model.npz"), J] {
                           const auto m = BodyModel::load(p.string());
                           m.pose(torch::zeros({1, m.num_joints(), 3}));
                           (void)J;
                         }});
    f.targets.push_back({"poses", seeds / "poses.npz", in("poses.npz"), Kind::Npz, [p = in("poses.npz"), J, names] {
                           PoseSet::load(p.string()).validate(p.string(), J, names);
                         }});
    f.targets.push_back({"binary_ply", seeds / "mesh.ply", in("mesh.ply"), Kind::Binary,
                         [p = in("mesh.ply")] { io::read_mesh(p.string()); }});
    f.targets.push_back({"ascii_ply", seeds / "ascii.ply", in("ascii.ply"), Kind::Text,
                         [p = in("ascii.ply")] { io::read_mesh(p.string()); }});
    f.targets.push_back({"obj", seeds / "mesh.obj", in("mesh.obj"), Kind::Text,
                         [p = in("mesh.obj")] { io::read_mesh(p.string()); }});
    f.targets.push_back({"config", seeds / "config.json", in("config.json"), Kind::Json,
                         [p = in("config.json")] { TrainConfig::load(p.string(), TrainConfig{}).validate(); }});
    f.targets.push_back({"glb", seeds / "rig.glb", in("rig.glb"), Kind::Binary,
                         [p = in("rig.glb")] { import_gltf(p.string()); }});
    f.targets.push_back({"gltf_json", seeds / "rig.gltf", in("rig.gltf"), Kind::Json,
                         [p = in("rig.gltf")] { import_gltf(p.string()); }});
    f.targets.push_back({"gltf_structure", seeds / "rig.gltf", in("rig_structure.gltf"), Kind::Gltf,
                         [p = in("rig_structure.gltf")] { import_gltf(p.string()); }});
    const auto skeleton = model.skeleton();
    f.targets.push_back({"bvh", seeds / "walk.bvh", in("walk.bvh"), Kind::Text,
                         [p = in("walk.bvh"), skeleton] { import_bvh(p.string(), skeleton); }});
    f.targets.push_back({"bvh_structure", seeds / "walk.bvh", in("walk_structure.bvh"), Kind::Bvh,
                         [p = in("walk_structure.bvh"), skeleton] { import_bvh(p.string(), skeleton); }});
    f.targets.push_back({"amass", seeds / "amass.npz", in("amass.npz"), Kind::Npz,
                         [p = in("amass.npz"), skeleton] { import_amass(p.string(), skeleton); }});
    if (have_dataset) {
      f.targets.push_back({"dataset_frame", seeds / "frame.npz", in("frame.npz"), Kind::Npz,
                           [p = in("frame.npz")] { DatasetFrame::load(p.string()); }});
      f.targets.push_back({"manifest", seeds / "manifest.json", data / "manifest.json", Kind::Json,
                           [d = data] { Dataset::load(d.string(), "train"); }});
    }
    return f;
  }();
  return f;
}

// An image dataset (cameras, character, poses, manifest, images, masks) and an
// avatar run trained for one step (its avatar.json), built only by the
// processes that fuzz them.
const Fixture& image_fixture() {
  static const Fixture f = [] {
    Fixture f;
    f.dir = testing::temp_dir("input_fuzz_images");
    const auto seeds = f.dir / "seeds";
    fs::create_directories(seeds);
    const auto data = (f.dir / "data").string();
    fs::copy(testing::tiny_image_dataset().dir, data, fs::copy_options::recursive);
    const auto train = fs::path(data) / "train";
    AvatarTrainOptions training;
    training.data_dir = data;
    training.out_dir = (f.dir / "run").string();
    training.avatar.field.encoding.levels = 4;
    training.avatar.field.encoding.log2_table_size = 10;
    training.avatar.field.hidden_dim = 16;
    training.avatar.skinning_grid_resolution = 16;
    training.avatar.canonical_grid_resolution = 16;
    training.avatar.posed_grid_resolution = 16;
    training.steps = 1;
    training.rays_per_step = 64;
    training.progress = false;
    train_avatar(training);
    // Each target reads the file it mutates in place; its seed is a copy.
    const auto in_place = [&](const std::string& name, const fs::path& file, Kind kind, std::function<void()> read) {
      const auto seed = seeds / (name + file.extension().string());
      fs::copy_file(file, seed);
      f.targets.push_back({name, seed, file, kind, std::move(read)});
    };
    const auto load_all_splits = [data] {
      const ImageDataset dataset(data);
      for (const auto& split : dataset.split_names()) dataset.load_split(split);
    };
    const auto load_train = [data] { ImageDataset(data).load_split("train"); };
    in_place("image_cameras", train / "cameras.npz", Kind::Npz, [p = train / "cameras.npz"] { load_cameras(p.string(), -1); });
    in_place("image_character", fs::path(data) / "canonical.npz", Kind::Npz, load_train);
    in_place("image_poses", train / "poses.npz", Kind::Npz, load_train);
    in_place("image_manifest", fs::path(data) / "manifest.json", Kind::Json, load_all_splits);
    in_place("image_png", train / "images" / "image_0000.png", Kind::Binary, load_train);
    in_place("image_mask_png", train / "masks" / "mask_0000.png", Kind::Binary, load_train);
    in_place("avatar_run", fs::path(training.out_dir) / "avatar.json", Kind::Json,
             [run = training.out_dir] { TrainedAvatar::load(run); });
    // Run-directory damage: the checkpoint's bytes (its CRC catches most; a
    // valid CRC over a damaged archive must still be an fskin::Error).
    in_place("avatar_checkpoint", fs::path(training.out_dir) / "checkpoint-00000001.fskin", Kind::Checkpoint,
             [run = training.out_dir] { TrainedAvatar::load(run); });
    return f;
  }();
  return f;
}

const std::vector<std::string>& target_names() {
  static const std::vector<std::string> names = {
      "model", "poses", "binary_ply", "ascii_ply", "obj", "config", "glb", "gltf_json", "bvh", "amass",
      "dataset_frame", "manifest", "image_cameras", "image_character", "image_poses", "image_manifest",
      "image_png", "image_mask_png", "avatar_run", "avatar_checkpoint", "gltf_structure", "bvh_structure"};
  return names;
}

class InputFuzz : public ::testing::TestWithParam<std::string> {};

TEST_P(InputFuzz, MutatedInputsAreAcceptedOrRejectedWithAnFskinError) {
  const std::string& name = GetParam();
  const bool image = name.rfind("image_", 0) == 0 || name.rfind("avatar_", 0) == 0;
  const Fixture& f = image ? image_fixture() : scan_fixture();
  const Target* found = f.find(name);
  if (!found) GTEST_SKIP() << "built without Embree: no dataset to mutate";
  const auto& target = *found;
  const size_t index = static_cast<size_t>(std::find(target_names().begin(), target_names().end(), name) -
                                           target_names().begin());
  const int64_t cases = env_int("FSKIN_FUZZ_CASES", 250);
  const bool verbose = env_int("FSKIN_FUZZ_VERBOSE", 0) != 0;
  Random rng(static_cast<uint64_t>(env_int("FSKIN_FUZZ_SEED", 1)) * 1000003u + index);
  const std::string seed_bytes = slurp(target.seed);
  // The unmutated file must be accepted, or every case is rejected for the
  // wrong reason and the target tests nothing.
  spit(target.path, seed_bytes);
  // Targets mutate files of a shared dataset in place: put the seed back
  // however this test ends, or the targets after it read a damaged dataset.
  struct Restore {
    const Target& target;
    const std::string& bytes;
    ~Restore() { spit(target.path, bytes); }
  } restore{target, seed_bytes};
  ASSERT_NO_THROW(target.read()) << target.name << ": the unmutated seed file is rejected";
  int64_t accepted = 0, rejected = 0;
  std::vector<std::string> internal;
  double slowest = 0;
  for (int64_t c = 0; c < cases; ++c) {
    std::string what, bytes;
    const bool structural = below(rng, 2) == 0;
    if (structural && target.kind == Kind::Npz) {
      bytes = mutate_npz(target.seed, f.dir / "structure.npz", rng, what);
    } else if (structural && target.kind == Kind::Json) {
      bytes = mutate_json(seed_bytes, rng, what);
    } else if (structural && target.kind == Kind::Checkpoint) {
      bytes = mutate_sealed_checkpoint(seed_bytes, rng, what);
    } else if (target.kind == Kind::Gltf) {
      bytes = mutate_gltf(seed_bytes, rng, what);
    } else if (target.kind == Kind::Bvh) {
      bytes = structural ? mutate_bvh(seed_bytes, rng, what) : mutate_lines(seed_bytes, rng, what);
    } else if (structural && target.kind == Kind::Text) {
      bytes = mutate_lines(seed_bytes, rng, what);
    } else {
      bytes = mutate_bytes(seed_bytes, rng, what);
    }
    spit(target.path, bytes);
    if (verbose) std::fprintf(stderr, "fuzz %s case %lld: %s\n", target.name.c_str(), static_cast<long long>(c), what.c_str());
    const auto start = std::chrono::steady_clock::now();
    try {
      target.read();
      ++accepted;
    } catch (const Error&) {
      ++rejected;
    } catch (const std::exception& e) {
      std::string message = e.what();
      message = message.substr(0, std::min(message.find('\n'), size_t{300}));
      internal.push_back(fmt::format("case {} ({}): {}", c, what, message));
      spit(f.dir / fmt::format("internal_{}_{}", index, c), bytes);
    }
    slowest = std::max(slowest, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::string examples;
  for (size_t i = 0; i < internal.size() && i < 8; ++i) examples += "\n  " + internal[i];
  EXPECT_TRUE(internal.empty()) << target.name << ": " << internal.size() << " of " << cases
                                << " cases raised an error that is not fskin::Error (files kept in " << f.dir << "):"
                                << examples;
  std::printf("%s: %lld cases, %lld accepted, %lld rejected with fskin::Error, %zu internal, slowest %.3f s\n",
              target.name.c_str(), static_cast<long long>(cases), static_cast<long long>(accepted),
              static_cast<long long>(rejected), internal.size(), slowest);
}

INSTANTIATE_TEST_SUITE_P(Targets, InputFuzz, ::testing::ValuesIn(target_names()),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

}  // namespace
}  // namespace fskin
