#pragma once
// Preset skinning weights from a body model (e.g. SMPL's), diffused from the
// canonical mesh into a voxel grid: every voxel takes the weights of its
// nearest vertex, then a few smoothing passes blur the seams between parts
// off the surface while voxels next to the surface keep the mesh's weights.
#include <memory>

#include "fskin/fields/voxel_skinning_field.h"

namespace fskin {

struct WeightDiffusionOptions {
  int smoothing_iterations = 10;
  // Voxels within this many voxel diagonals of a vertex keep their nearest-vertex weights.
  double surface_band = 1.0;
};

// vertices [V, 3] in canonical space, weights [V, J] -> a frozen grid field over box.
std::shared_ptr<FrozenSkinningField> diffuse_weights_to_grid(const torch::Tensor& vertices,
                                                             const torch::Tensor& weights, const VoxelBox& box,
                                                             const WeightDiffusionOptions& options = {});

}  // namespace fskin
