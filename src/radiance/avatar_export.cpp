#include "fskin/radiance/avatar_export.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/radiance/avatar_mesh.h"

namespace fskin {

SkinnedCharacter rigged_image_avatar(Avatar& avatar, const Skeleton& canonical_skeleton, int64_t resolution,
                                     const torch::Tensor& bones, double fps) {
  torch::NoGradGuard no_grad;
  auto& field = avatar->deformer().field();
  FSKIN_CHECK(canonical_skeleton.num_joints() == field.num_bones(),
              "avatar export: the skeleton has {} joints, the avatar's skinning grid {}", canonical_skeleton.num_joints(),
              field.num_bones());
  SkinnedCharacter character;
  character.mesh = avatar_mesh(avatar, resolution);
  // The weights the avatar is posed with, so the asset moves as the avatar renders.
  const auto device = avatar->field()->table().device();
  character.weights =
      field.weights(character.mesh.vertices.to(device, torch::kFloat32).unsqueeze(0))[0].to(torch::kCPU, torch::kFloat32);
  character.skeleton = canonical_skeleton;
  character.skeleton.rest_joints = canonical_skeleton.rest_joints.to(torch::kFloat32);
  character.fps = fps;
  if (bones.defined() && bones.numel() > 0) character.animation = animation_from_bones(character.skeleton, bones);
  return character;
}

}  // namespace fskin
