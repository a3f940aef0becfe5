#pragma once
// Skinning-weight fields w: R^3 -> R^J in canonical space (SNARF eq. 3), behind
// one small interface. Grid-backed fields additionally expose their voxel
// weights, which the Fast-SNARF deformer blends into per-voxel transforms.
#include <torch/torch.h>

#include "fskin/geometry/voxel_box.h"

namespace fskin {

class SkinningField : public torch::nn::Module {
 public:
  virtual int64_t num_bones() const = 0;
  // Canonical points [..., 3] -> weights [..., J] (>= 0, summing to 1).
  virtual torch::Tensor weights(const torch::Tensor& x_canonical) = 0;
  // Whether gradients can reach the field, so that a deformer attaches
  // implicit gradients to its roots: by default whether any parameter
  // requires them.
  virtual bool requires_grad() const;
};

class GridSkinningField : public SkinningField {
 public:
  virtual const VoxelBox& box() const = 0;
  // Weights at every voxel centre, channels-last [D, H, W, J].
  virtual torch::Tensor grid_weights() = 0;
  // Trilinear interpolation of grid_weights() (Fast-SNARF eq. 13).
  torch::Tensor weights(const torch::Tensor& x_canonical) override;
};

}  // namespace fskin
