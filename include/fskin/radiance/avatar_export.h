#pragma once
// An image avatar as a rigged asset (`fskin avatar export`): the coloured
// level-set mesh of its canonical density (avatar_mesh.h), the skinning
// weights its deformer poses with at those vertices (the character's weights
// diffused into the skinning grid), the dataset's skeleton in the canonical
// pose, and optionally bone transforms as an animation. Engines and Blender
// then play it as a rigged, vertex-coloured character (export/skinned_gltf.h).
#include <torch/types.h>

#include "fskin/export/skinned_gltf.h"
#include "fskin/radiance/avatar.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

// canonical_skeleton: the dataset's (names, parents, canonical joints);
// resolution: as avatar_mesh; bones [T, J, 4, 4] canonical -> posed or
// undefined (no animation). Throws fskin::Error for an untrained avatar or a
// skeleton that is not the avatar's.
SkinnedCharacter rigged_image_avatar(Avatar& avatar, const Skeleton& canonical_skeleton, int64_t resolution,
                                     const torch::Tensor& bones, double fps);

}  // namespace fskin
