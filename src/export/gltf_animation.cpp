#include "fskin/export/gltf_animation.h"

#include <tiny_gltf.h>
#include <torch/torch.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <sstream>

#include "fskin/core/error.h"
#include "io/gltf_file.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/geometry/mesh.h"
#include "fskin/util/atomic_file.h"

namespace fskin {
namespace {

using gltf::BufferWriter;
using gltf::is_binary_path;
using gltf::read_accessor;

torch::Tensor to_tensor(const std::vector<double>& values, std::initializer_list<int64_t> shape,
                        torch::ScalarType type) {
  return torch::tensor(values, torch::kFloat64).reshape(shape).to(type);
}

}  // namespace

void MeshAnimation::validate(const std::string& context) const {
  FSKIN_CHECK(frames.defined() && faces.defined(), "{}: animation needs frames and faces",
              context);
  expect_shape(frames, {-1, -1, 3}, context + ": frames");
  FSKIN_CHECK(frames.size(0) > 0 && frames.size(1) > 0,
              "{}: frames {} must hold at least one frame of at least one vertex", context,
              shape_string(frames.sizes()));
  FSKIN_CHECK(fps >= 1e-3 && fps <= 1e5, "{}: fps {} is not a frame rate (1e-3 to 1e5 expected)", context, fps);
  for (int64_t t = 0; t < frames.size(0); ++t) {
    const Mesh mesh{frames[t], faces, colors};
    mesh.validate(fmt::format("{}: frame {}", context, t));
  }
  FSKIN_CHECK(faces.size(0) > 0, "{}: animation has no faces", context);
  if (colors.defined())
    FSKIN_CHECK(colors.scalar_type() == torch::kUInt8, "{}: colors must be uint8", context);
}

void write_gltf_animation(const std::string& path, const MeshAnimation& animation) {
  const bool binary = is_binary_path(path);
  animation.validate(path);
  const int64_t num_frames = animation.num_frames();
  const int64_t num_targets = num_frames - 1;
  const auto frames = animation.frames.contiguous();
  std::vector<torch::Tensor> normals;
  for (int64_t t = 0; t < num_frames; ++t)
    normals.push_back(vertex_normals(Mesh{frames[t], animation.faces, {}}));

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "fskin";
  BufferWriter writer(model);

  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  // Stored as UNSIGNED_INT; int32 holds the same bits for indices < 2^31.
  FSKIN_CHECK(frames.size(1) <= std::numeric_limits<int32_t>::max(),
              "{}: {} vertices do not fit 32-bit glTF indices", path, frames.size(1));
  const auto indices = animation.faces.to(torch::kInt32).contiguous();
  tinygltf::Accessor index_accessor;
  index_accessor.bufferView = writer.add_view(indices.data_ptr<int32_t>(),
                                              indices.numel() * sizeof(int32_t),
                                              TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  index_accessor.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  index_accessor.type = TINYGLTF_TYPE_SCALAR;
  index_accessor.count = static_cast<size_t>(indices.numel());
  primitive.indices = writer.add_accessor(index_accessor);
  primitive.attributes["POSITION"] =
      writer.add_floats(frames[0], TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER);
  primitive.attributes["NORMAL"] =
      writer.add_floats(normals[0], TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER);
  if (animation.colors.defined()) {
    // RGBA: vertex attribute elements must be 4-byte aligned, RGB8 is not.
    const auto rgba =
        torch::cat({animation.colors.to(torch::kUInt8),
                    torch::full({animation.colors.size(0), 1}, 255, torch::kUInt8)},
                   1)
            .contiguous();
    tinygltf::Accessor color_accessor;
    color_accessor.bufferView = writer.add_view(rgba.data_ptr<uint8_t>(), rgba.numel(),
                                                TINYGLTF_TARGET_ARRAY_BUFFER);
    color_accessor.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
    color_accessor.normalized = true;
    color_accessor.type = TINYGLTF_TYPE_VEC4;
    color_accessor.count = static_cast<size_t>(rgba.size(0));
    primitive.attributes["COLOR_0"] = writer.add_accessor(color_accessor);
  }
  std::vector<tinygltf::Value> target_names;
  for (int64_t t = 1; t < num_frames; ++t) {
    primitive.targets.push_back(
        {{"POSITION", writer.add_floats(frames[t] - frames[0], TINYGLTF_TYPE_VEC3,
                                        TINYGLTF_TARGET_ARRAY_BUFFER)},
         {"NORMAL", writer.add_floats(normals[t] - normals[0], TINYGLTF_TYPE_VEC3,
                                      TINYGLTF_TARGET_ARRAY_BUFFER)}});
    target_names.emplace_back(fmt::format("frame_{:04d}", t));
  }

  tinygltf::Material material;
  material.name = "fskin";
  material.pbrMetallicRoughness.baseColorFactor = {0.8, 0.8, 0.82, 1.0};
  if (animation.colors.defined()) material.pbrMetallicRoughness.baseColorFactor = {1, 1, 1, 1};
  material.pbrMetallicRoughness.metallicFactor = 0;
  material.pbrMetallicRoughness.roughnessFactor = 0.7;
  material.doubleSided = true;
  model.materials.push_back(material);
  primitive.material = 0;

  tinygltf::Mesh mesh;
  mesh.name = "fskin_animation";
  mesh.primitives.push_back(primitive);
  if (num_targets > 0) {
    mesh.weights.assign(num_targets, 0.0);
    // Blender and three.js name shape keys / morph targets from this list.
    tinygltf::Value::Object extras;
    extras["targetNames"] = tinygltf::Value(target_names);
    mesh.extras = tinygltf::Value(extras);
  }
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.name = "fskin_animation";
  node.mesh = 0;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  if (num_targets > 0) {
    // Keyframe t shows frame t: all weights 0 at t = 0, else target t-1 alone.
    const auto times =
        torch::arange(num_frames, torch::kFloat64).div(animation.fps).to(torch::kFloat32);
    const auto weights = torch::cat({torch::zeros({1, num_targets}),
                                     torch::eye(num_targets, torch::kFloat32)})
                             .reshape({-1, 1});
    tinygltf::AnimationSampler sampler;
    sampler.input = writer.add_floats(times, TINYGLTF_TYPE_SCALAR, 0);
    sampler.output = writer.add_floats(weights, TINYGLTF_TYPE_SCALAR, 0);
    sampler.interpolation = "STEP";
    tinygltf::AnimationChannel channel;
    channel.sampler = 0;
    channel.target_node = 0;
    channel.target_path = "weights";
    tinygltf::Animation clip;
    clip.name = "fskin_animation";
    clip.samplers.push_back(sampler);
    clip.channels.push_back(channel);
    model.animations.push_back(clip);
  }

  gltf::save(path, model, binary);
}

MeshAnimation read_gltf_animation(const std::string& path) {
  const tinygltf::Model model = gltf::load(path);
  FSKIN_CHECK(model.meshes.size() == 1 && model.meshes[0].primitives.size() == 1,
              "{}: expected one mesh with one primitive, found {} meshes", path,
              model.meshes.size());
  const auto& primitive = model.meshes[0].primitives[0];
  FSKIN_CHECK(primitive.mode == TINYGLTF_MODE_TRIANGLES || primitive.mode == -1,
              "{}: primitive mode {} is not triangles", path, primitive.mode);
  const auto attribute = [&](const std::map<std::string, int>& attributes,
                             const std::string& name) {
    const auto found = attributes.find(name);
    FSKIN_CHECK(found != attributes.end(), "{}: primitive has no {}", path, name);
    return found->second;
  };

  MeshAnimation animation;
  const auto base_values =
      read_accessor(model, attribute(primitive.attributes, "POSITION"), TINYGLTF_TYPE_VEC3, path,
                    "POSITION");
  const auto num_vertices = static_cast<int64_t>(base_values.size() / 3);
  const auto base = to_tensor(base_values, {num_vertices, 3}, torch::kFloat32);
  const auto index_values =
      read_accessor(model, primitive.indices, TINYGLTF_TYPE_SCALAR, path, "indices");
  FSKIN_CHECK(index_values.size() % 3 == 0, "{}: {} indices do not form triangles", path,
              index_values.size());
  animation.faces =
      to_tensor(index_values, {static_cast<int64_t>(index_values.size() / 3), 3}, torch::kInt64);
  if (primitive.attributes.count("COLOR_0")) {
    const int index = primitive.attributes.at("COLOR_0");
    FSKIN_CHECK(index >= 0 && index < static_cast<int>(model.accessors.size()),
                "{}: COLOR_0 refers to missing accessor {}", path, index);
    const auto& accessor = model.accessors[index];
    FSKIN_CHECK(accessor.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                "{}: COLOR_0 must be unsigned bytes", path);
    auto values = read_accessor(model, index, accessor.type, path, "COLOR_0");
    if (accessor.normalized)  // read as [0, 1]: back to bytes
      for (double& v : values) v = std::round(v * 255.0);
    const int components = tinygltf::GetNumComponentsInType(accessor.type);
    FSKIN_CHECK(components == 3 || components == 4, "{}: COLOR_0 must be RGB or RGBA", path);
    animation.colors = to_tensor(values, {num_vertices, components}, torch::kUInt8)
                           .narrow(1, 0, 3)
                           .contiguous();
  }

  std::vector<torch::Tensor> deltas;
  for (size_t k = 0; k < primitive.targets.size(); ++k) {
    const std::string what = fmt::format("morph target {} POSITION", k);
    const auto values = read_accessor(model, attribute(primitive.targets[k], "POSITION"),
                                      TINYGLTF_TYPE_VEC3, path, what);
    FSKIN_CHECK(static_cast<int64_t>(values.size()) == 3 * num_vertices,
                "{}: {} has {} values, expected {}", path, what, values.size(), 3 * num_vertices);
    deltas.push_back(to_tensor(values, {num_vertices, 3}, torch::kFloat64));
  }
  if (model.animations.empty()) {
    FSKIN_CHECK(deltas.empty(), "{}: morph targets without an animation", path);
    animation.frames = base.unsqueeze(0);
  } else {
    const auto& clip = model.animations[0];
    FSKIN_CHECK(clip.channels.size() == 1 && clip.channels[0].target_path == "weights" &&
                    clip.channels[0].sampler >= 0 &&
                    clip.channels[0].sampler < static_cast<int>(clip.samplers.size()),
                "{}: expected one weights animation channel", path);
    const auto& sampler = clip.samplers[clip.channels[0].sampler];
    const auto times = read_accessor(model, sampler.input, TINYGLTF_TYPE_SCALAR, path,
                                     "animation times");
    const auto weights = read_accessor(model, sampler.output, TINYGLTF_TYPE_SCALAR, path,
                                       "animation weights");
    const auto num_frames = static_cast<int64_t>(times.size());
    const auto num_targets = static_cast<int64_t>(deltas.size());
    FSKIN_CHECK(num_frames > 0 && num_targets > 0 &&
                    static_cast<int64_t>(weights.size()) == num_frames * num_targets,
                "{}: {} keyframes, {} morph targets and {} weights do not match", path,
                num_frames, num_targets, weights.size());
    // frame t = base + sum_k w_tk delta_k (glTF morphing).
    const auto offsets = to_tensor(weights, {num_frames, num_targets}, torch::kFloat64)
                             .matmul(torch::stack(deltas).reshape({num_targets, -1}))
                             .reshape({num_frames, num_vertices, 3});
    animation.frames = (base.to(torch::kFloat64).unsqueeze(0) + offsets).to(torch::kFloat32);
    if (num_frames > 1) animation.fps = (num_frames - 1) / (times.back() - times.front());
  }
  animation.validate(path);
  return animation;
}

}  // namespace fskin
