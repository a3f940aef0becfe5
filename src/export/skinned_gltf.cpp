#include "fskin/export/skinned_gltf.h"

#include <torch/torch.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/geometry/character_size.h"
#include "fskin/skeleton/pose_from_bones.h"
#include "fskin/skeleton/rotations.h"
#include "io/gltf_file.h"

namespace fskin {

void SkinnedCharacter::validate(const std::string& context) const {
  RiggedMesh::validate(context);
  FSKIN_CHECK(skeleton.num_joints() <= 65535, "{}: {} joints do not fit glTF's 16-bit joint indices", context,
              skeleton.num_joints());
  if (animation.size() > 0) animation.validate(context + ": animation", skeleton.num_joints());
  FSKIN_CHECK(fps >= 1e-3 && fps <= 1e5, "{}: fps {} is not a frame rate (1e-3 to 1e5 expected)", context, fps);
  FSKIN_CHECK(influences >= 0, "{}: influences {} must be >= 0 (0: every joint)", context, influences);
}

std::pair<torch::Tensor, torch::Tensor> top_influences(const torch::Tensor& weights, int64_t k) {
  expect_shape(weights, {-1, -1}, "top_influences: weights");
  const int64_t kept = std::min<int64_t>(k, weights.size(1));
  auto [values, indices] = weights.to(torch::kFloat32).clamp_min(0).topk(kept, 1);
  const auto total = values.sum(1, true);
  FSKIN_CHECK((total > 0).all().item<bool>(), "top_influences: a vertex has no positive weight");
  values = values / total;
  if (kept < k) {  // pad: glTF's JOINTS_0 / WEIGHTS_0 hold four
    values = torch::cat({values, torch::zeros({values.size(0), k - kept})}, 1);
    indices = torch::cat({indices, torch::zeros({indices.size(0), k - kept}, torch::kInt64)}, 1);
  }
  return {indices, values};
}

PoseSet animation_from_bones(const Skeleton& skeleton, const torch::Tensor& bones) {
  const auto joints = skeleton.rest_joints.to(torch::kFloat32);
  const auto pose = pose_from_bone_transforms(skeleton.parents, joints, bones);
  PoseSet animation;
  animation.poses = pose.local_rotations;
  animation.trans = pose.root_translation;
  if (pose.max_joint_drift > 1e-6 * character_size(joints)) animation.joint_translations = pose.joint_translations;
  animation.joint_names = skeleton.joint_names;
  return animation;
}

void write_skinned_gltf(const std::string& path, const SkinnedCharacter& character) {
  character.validate(path);
  const bool binary = gltf::is_binary_path(path);
  const int64_t V = character.mesh.num_vertices(), J = character.skeleton.num_joints();
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "fskin";
  gltf::BufferWriter writer(model);

  // Mesh: positions, uint32 indices, the largest influences' joints (uint16) and weights.
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.attributes["POSITION"] =
      writer.add_floats(character.mesh.vertices, TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER);
  if (character.mesh.colors.defined()) {
    // COLOR_0 is linear RGB; fskin's colours are 8-bit sRGB (as images hold them).
    FSKIN_CHECK(character.mesh.colors.sizes() == torch::IntArrayRef({V, 3}), "{}: colours must be [V, 3], got {}",
                path, c10::str(character.mesh.colors.sizes()));
    const auto srgb = character.mesh.colors.to(torch::kFloat32) / 255.0f;
    const auto linear = torch::where(srgb <= 0.04045f, srgb / 12.92f, ((srgb + 0.055f) / 1.055f).pow(2.4f)).contiguous();
    const int colors = writer.add_floats(linear, TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER);
    model.accessors[colors].minValues.clear();
    model.accessors[colors].maxValues.clear();
    primitive.attributes["COLOR_0"] = colors;
  }
  const auto faces = character.mesh.faces.to(torch::kInt32).contiguous();
  tinygltf::Accessor indices;
  indices.bufferView =
      writer.add_view(faces.data_ptr<int32_t>(), faces.numel() * sizeof(int32_t), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  indices.type = TINYGLTF_TYPE_SCALAR;
  indices.count = static_cast<size_t>(faces.numel());
  primitive.indices = writer.add_accessor(indices);
  const int64_t kept = character.influences == 0 ? J : std::min(character.influences, J);
  const int64_t sets = (kept + 3) / 4;
  auto [joint_ids, joint_weights] = top_influences(character.weights, kept);
  if (4 * sets > kept) {  // pad the last set with zero weights
    joint_weights = torch::cat({joint_weights, torch::zeros({V, 4 * sets - kept})}, 1);
    joint_ids = torch::cat({joint_ids, torch::zeros({V, 4 * sets - kept}, torch::kInt64)}, 1);
  }
  // glTF wants joint 0 wherever the weight is 0 (ACCESSOR_JOINTS_USED_ZERO_WEIGHT).
  joint_ids = torch::where(joint_weights > 0, joint_ids, torch::zeros_like(joint_ids));
  for (int64_t set = 0; set < sets; ++set) {
    // JOINTS_n as uint16 (validate() caps the joints at 65535).
    const auto ids = joint_ids.narrow(1, 4 * set, 4).contiguous();
    std::vector<uint16_t> ids16(static_cast<size_t>(ids.numel()));
    for (size_t i = 0; i < ids16.size(); ++i) ids16[i] = static_cast<uint16_t>(ids.data_ptr<int64_t>()[i]);
    tinygltf::Accessor joints;
    joints.bufferView = writer.add_view(ids16.data(), ids16.size() * sizeof(uint16_t), TINYGLTF_TARGET_ARRAY_BUFFER);
    joints.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    joints.type = TINYGLTF_TYPE_VEC4;
    joints.count = static_cast<size_t>(V);
    primitive.attributes["JOINTS_" + std::to_string(set)] = writer.add_accessor(joints);
    const int weights_accessor = writer.add_floats(joint_weights.narrow(1, 4 * set, 4).contiguous(), TINYGLTF_TYPE_VEC4,
                                                   TINYGLTF_TARGET_ARRAY_BUFFER);
    // Only positions need min/max; keep the weights' accessors lean.
    model.accessors[weights_accessor].minValues.clear();
    model.accessors[weights_accessor].maxValues.clear();
    primitive.attributes["WEIGHTS_" + std::to_string(set)] = weights_accessor;
  }
  tinygltf::Material material;
  material.name = "skin";
  material.pbrMetallicRoughness.baseColorFactor = {0.8, 0.8, 0.8, 1.0};
  material.doubleSided = false;
  model.materials.push_back(material);
  primitive.material = 0;
  tinygltf::Mesh mesh;
  mesh.name = "character";
  mesh.primitives.push_back(primitive);
  model.meshes.push_back(mesh);

  // Joint nodes 0..J-1 in fskin's order, then the mesh node.
  const auto rest = character.skeleton.rest_joints.to(torch::kFloat64).contiguous();
  const auto rest_at = [&](int64_t j, int a) { return rest.data_ptr<double>()[3 * j + a]; };
  const auto& parents = character.skeleton.parents;
  for (int64_t j = 0; j < J; ++j) {
    tinygltf::Node node;
    node.name = character.skeleton.joint_names[j];
    for (int a = 0; a < 3; ++a) node.translation.push_back(rest_at(j, a) - (parents[j] < 0 ? 0.0 : rest_at(parents[j], a)));
    model.nodes.push_back(node);
  }
  for (int64_t j = 1; j < J; ++j) model.nodes[parents[j]].children.push_back(static_cast<int>(j));
  auto inverse_bind = torch::eye(4, torch::kFloat64).repeat({J, 1, 1});
  inverse_bind.narrow(1, 0, 3).select(2, 3).copy_(-rest);
  // glTF matrices are column-major: store the transpose of each row-major matrix.
  tinygltf::Skin skin;
  skin.name = "skeleton";
  skin.skeleton = 0;
  for (int64_t j = 0; j < J; ++j) skin.joints.push_back(static_cast<int>(j));
  const auto column_major = inverse_bind.transpose(1, 2).to(torch::kFloat32).contiguous().view({J, 16});
  const int ibm = writer.add_floats(column_major, TINYGLTF_TYPE_MAT4, 0);
  model.accessors[ibm].minValues.clear();
  model.accessors[ibm].maxValues.clear();
  skin.inverseBindMatrices = ibm;
  model.skins.push_back(skin);
  tinygltf::Node mesh_node;
  mesh_node.name = "character";
  mesh_node.mesh = 0;
  mesh_node.skin = 0;
  model.nodes.push_back(mesh_node);
  tinygltf::Scene scene;
  scene.nodes = {0, static_cast<int>(J)};
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  const int64_t T = character.animation.size();
  if (T > 0) {
    const auto times = torch::arange(T, torch::kFloat64) / character.fps;
    const int input = writer.add_floats(times.unsqueeze(1), TINYGLTF_TYPE_SCALAR, 0);
    tinygltf::Animation clip;
    clip.name = character.animation_name;
    // fskin quaternions are (w, x, y, z); glTF's are (x, y, z, w).
    const auto q = matrix_to_quaternion(axis_angle_to_matrix(character.animation.poses.to(torch::kFloat64)));
    const auto xyzw = torch::cat({q.narrow(-1, 1, 3), q.narrow(-1, 0, 1)}, -1);  // [T, J, 4]
    // One LINEAR channel: values [T, components] for node j's `target` path.
    const auto add_channel = [&](const torch::Tensor& values, int type, int64_t j, const char* target) {
      tinygltf::AnimationSampler sampler;
      sampler.input = input;
      sampler.interpolation = "LINEAR";
      sampler.output = writer.add_floats(values.contiguous(), type, 0);
      model.accessors[sampler.output].minValues.clear();
      model.accessors[sampler.output].maxValues.clear();
      clip.samplers.push_back(sampler);
      tinygltf::AnimationChannel channel;
      channel.sampler = static_cast<int>(clip.samplers.size()) - 1;
      channel.target_node = static_cast<int>(j);
      channel.target_path = target;
      clip.channels.push_back(channel);
    };
    for (int64_t j = 0; j < J; ++j) add_channel(xyzw.select(1, j), TINYGLTF_TYPE_VEC4, j, "rotation");
    const auto& parents = character.skeleton.parents;
    const auto& moved = character.animation.joint_translations;
    for (int64_t j = 0; j < J; ++j) {
      torch::Tensor translation;  // [T, 3] the node's local translation per pose
      if (parents[j] < 0) {
        translation = character.animation.trans.to(torch::kFloat64) + rest[j];
        if (moved.defined()) translation = translation + moved.select(1, j).to(torch::kFloat64);
      } else if (moved.defined()) {
        translation = moved.select(1, j).to(torch::kFloat64) + (rest[j] - rest[parents[j]]);
      } else {
        continue;
      }
      add_channel(translation, TINYGLTF_TYPE_VEC3, j, "translation");
    }
    model.animations.push_back(clip);
  }
  gltf::save(path, model, binary);
}

}  // namespace fskin
