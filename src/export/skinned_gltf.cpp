#include "fskin/export/skinned_gltf.h"

#include <torch/torch.h>

#include <algorithm>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/geometry/character_size.h"
#include "fskin/skeleton/pose_from_bones.h"
#include "export/gltf_skin.h"
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
  const int64_t V = character.mesh.num_vertices();
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
    primitive.attributes["COLOR_0"] =
        writer.add_floats(linear, TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER, /*bounds=*/false);
  }
  const auto faces = character.mesh.faces.to(torch::kInt32).contiguous();
  tinygltf::Accessor indices;
  indices.bufferView =
      writer.add_view(faces.data_ptr<int32_t>(), faces.numel() * sizeof(int32_t), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  indices.type = TINYGLTF_TYPE_SCALAR;
  indices.count = static_cast<size_t>(faces.numel());
  primitive.indices = writer.add_accessor(indices);
  gltf::add_skin_influences(model, writer, primitive, character.weights, character.influences);
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

  gltf::add_skinned_node(model, writer, character.skeleton, 0, "character");
  if (character.animation.size() > 0) {
    gltf::add_joint_animation(model, writer, character.skeleton, character.animation, character.fps,
                              character.animation_name);
  }
  gltf::save(path, model, binary);
}

}  // namespace fskin
