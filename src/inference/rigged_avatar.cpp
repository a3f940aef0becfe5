#include "fskin/inference/rigged_avatar.h"

#include <torch/torch.h>

#include "fskin/core/device.h"
#include "fskin/core/error.h"

namespace fskin {

SkinnedCharacter rigged_avatar(OccupancyModel& model, const std::string& method, const CanonicalSkeleton& skeleton,
                               const Mesh& canonical_mesh, const torch::Tensor& bones, double fps) {
  FSKIN_CHECK(method == "fast-snarf" || method == "snarf",
              "export: a rigged avatar needs LBS of a canonical shape (fast-snarf or snarf runs); method '{}' {}",
              method,
              method == "ins" ? "adds pose-dependent PIN deformations that a glTF skin cannot hold"
                              : "has no canonical skinning weights");
  // The weights the deformer poses with (Fast-SNARF: the distilled grid), so
  // the asset moves as `fskin animate --repose` moves the same mesh.
  model.train(false);
  model.freeze_for_inference();
  auto* field = model.deformer_skinning_field();
  FSKIN_CHECK(field != nullptr, "export: the {} model has no skinning field", method);
  FSKIN_CHECK(canonical_mesh.num_faces() > 0, "export: the canonical mesh is empty");
  SkinnedCharacter character;
  character.mesh = canonical_mesh;
  character.mesh.colors = torch::Tensor();
  {
    torch::NoGradGuard no_grad;
    character.weights = field->weights(canonical_mesh.vertices.to(module_device(*field), torch::kFloat32))
                            .to(torch::kCPU, torch::kFloat32);
  }
  character.skeleton.joint_names = skeleton.joint_names;
  character.skeleton.parents = skeleton.parents;
  character.skeleton.rest_joints = skeleton.joints.to(torch::kFloat32);
  character.fps = fps;
  if (bones.defined() && bones.numel() > 0) character.animation = animation_from_bones(character.skeleton, bones);
  return character;
}

}  // namespace fskin
