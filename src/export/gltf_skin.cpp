#include "export/gltf_skin.h"

#include <torch/torch.h>

#include <cstdint>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/skeleton/rotations.h"

namespace fskin::gltf {

void add_skin_influences(tinygltf::Model& model, BufferWriter& writer, tinygltf::Primitive& primitive,
                         const torch::Tensor& weights, int64_t influences) {
  const int64_t V = weights.size(0), J = weights.size(1);
  const int64_t kept = influences == 0 ? J : std::min(influences, J);
  const int64_t sets = (kept + 3) / 4;
  auto [joint_ids, joint_weights] = top_influences(weights, kept);
  if (4 * sets > kept) {  // pad the last set with zero weights
    joint_weights = torch::cat({joint_weights, torch::zeros({V, 4 * sets - kept})}, 1);
    joint_ids = torch::cat({joint_ids, torch::zeros({V, 4 * sets - kept}, torch::kInt64)}, 1);
  }
  // glTF wants joint 0 wherever the weight is 0 (ACCESSOR_JOINTS_USED_ZERO_WEIGHT).
  joint_ids = torch::where(joint_weights > 0, joint_ids, torch::zeros_like(joint_ids));
  for (int64_t set = 0; set < sets; ++set) {
    const auto ids = joint_ids.narrow(1, 4 * set, 4).contiguous();
    std::vector<uint16_t> ids16(static_cast<size_t>(ids.numel()));
    for (size_t i = 0; i < ids16.size(); ++i) ids16[i] = static_cast<uint16_t>(ids.data_ptr<int64_t>()[i]);
    tinygltf::Accessor joints;
    joints.bufferView = writer.add_view(ids16.data(), ids16.size() * sizeof(uint16_t), TINYGLTF_TARGET_ARRAY_BUFFER);
    joints.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    joints.type = TINYGLTF_TYPE_VEC4;
    joints.count = static_cast<size_t>(V);
    primitive.attributes["JOINTS_" + std::to_string(set)] = writer.add_accessor(joints);
    primitive.attributes["WEIGHTS_" + std::to_string(set)] = writer.add_floats(
        joint_weights.narrow(1, 4 * set, 4), TINYGLTF_TYPE_VEC4, TINYGLTF_TARGET_ARRAY_BUFFER, /*bounds=*/false);
  }
}

int add_skinned_node(tinygltf::Model& model, BufferWriter& writer, const Skeleton& skeleton, int mesh,
                     const std::string& name) {
  FSKIN_CHECK(model.nodes.empty(), "add_skinned_node: the joints must be nodes 0..J-1");
  const int64_t J = skeleton.num_joints();
  const auto rest = skeleton.rest_joints.to(torch::kFloat64).contiguous();
  const auto rest_at = [&](int64_t j, int a) { return rest.data_ptr<double>()[3 * j + a]; };
  const auto& parents = skeleton.parents;
  for (int64_t j = 0; j < J; ++j) {
    tinygltf::Node node;
    node.name = skeleton.joint_names[j];
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
  skin.inverseBindMatrices = writer.add_floats(column_major, TINYGLTF_TYPE_MAT4, 0, /*bounds=*/false);
  model.skins.push_back(skin);
  tinygltf::Node mesh_node;
  mesh_node.name = name;
  mesh_node.mesh = mesh;
  mesh_node.skin = static_cast<int>(model.skins.size()) - 1;
  model.nodes.push_back(mesh_node);
  tinygltf::Scene scene;
  scene.nodes = {0, static_cast<int>(J)};
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  return mesh_node.skin;
}

void add_joint_animation(tinygltf::Model& model, BufferWriter& writer, const Skeleton& skeleton,
                         const PoseSet& animation, double fps, const std::string& name) {
  const int64_t T = animation.size(), J = skeleton.num_joints();
  const auto rest = skeleton.rest_joints.to(torch::kFloat64).contiguous();
  const auto times = torch::arange(T, torch::kFloat64) / fps;
  const int input = writer.add_floats(times.unsqueeze(1), TINYGLTF_TYPE_SCALAR, 0);
  tinygltf::Animation clip;
  clip.name = name;
  // fskin quaternions are (w, x, y, z); glTF's are (x, y, z, w).
  const auto q = matrix_to_quaternion(axis_angle_to_matrix(animation.poses.to(torch::kFloat64)));
  const auto xyzw = torch::cat({q.narrow(-1, 1, 3), q.narrow(-1, 0, 1)}, -1);  // [T, J, 4]
  // One LINEAR channel: values [T, components] for node j's `target` path.
  const auto add_channel = [&](const torch::Tensor& values, int type, int64_t j, const char* target) {
    tinygltf::AnimationSampler sampler;
    sampler.input = input;
    sampler.interpolation = "LINEAR";
    sampler.output = writer.add_floats(values, type, 0, /*bounds=*/false);
    clip.samplers.push_back(sampler);
    tinygltf::AnimationChannel channel;
    channel.sampler = static_cast<int>(clip.samplers.size()) - 1;
    channel.target_node = static_cast<int>(j);
    channel.target_path = target;
    clip.channels.push_back(channel);
  };
  for (int64_t j = 0; j < J; ++j) add_channel(xyzw.select(1, j), TINYGLTF_TYPE_VEC4, j, "rotation");
  const auto& parents = skeleton.parents;
  const auto& moved = animation.joint_translations;
  for (int64_t j = 0; j < J; ++j) {
    torch::Tensor translation;  // [T, 3] the node's local translation per pose
    if (parents[j] < 0) {
      translation = animation.trans.to(torch::kFloat64) + rest[j];
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

}  // namespace fskin::gltf
