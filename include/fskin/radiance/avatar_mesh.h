#pragma once
// The avatar's surface as a coloured triangle mesh: the level set of the
// canonical density where one sample step of a ray reaches opacity 1/2,
// coloured by the field at each vertex, optionally moved into a pose by the
// avatar's skinning (LBS with its skinning grid).
#include <torch/types.h>

#include "fskin/geometry/mesh.h"
#include "fskin/radiance/avatar.h"

namespace fskin {

// resolution: grid samples along the canonical box's longest side; bones
// [J, 4, 4] canonical -> posed, or undefined for the canonical mesh. Throws
// fskin::Error when the density nowhere reaches the level (an untrained avatar).
Mesh avatar_mesh(Avatar& avatar, int64_t resolution, const torch::Tensor& bones = {});

}  // namespace fskin
