#pragma once
// A learned avatar as a rigged asset (`fskin export`): the canonical mesh of a
// trained run, the learned skinning weights at its vertices (those the
// deformer poses with: Fast-SNARF's distilled grid, SNARF's network, so the
// asset moves as `fskin animate --repose` moves the same mesh), and the
// skeleton in the canonical pose, so engines and Blender play it as a normal
// rigged character (export/skinned_gltf.h keeps the four largest weights per
// vertex unless asked for more).
// Only the forward-skinning methods (SNARF, Fast-SNARF) are exactly LBS of
// their canonical shape; INS adds pose-dependent PIN deformations that a
// glTF skin cannot hold, and the baselines have no canonical weights.
#include <torch/types.h>

#include "fskin/data/canonical_skeleton.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/geometry/mesh.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

// bones: [T, J, 4, 4] canonical -> posed (as the dataset computes them), or
// undefined for no animation. Throws fskin::Error naming `method` for models
// without canonical skinning weights or with pose-dependent corrections.
SkinnedCharacter rigged_avatar(OccupancyModel& model, const std::string& method, const CanonicalSkeleton& skeleton,
                               const Mesh& canonical_mesh, const torch::Tensor& bones, double fps);

}  // namespace fskin
