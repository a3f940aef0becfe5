#pragma once
// Voxel skinning fields (Fast-SNARF sec. 4.1-4.2).
//  - DistilledSkinningField: the MLP evaluated at every voxel centre on each
//    call ("distillation", sec. 4.2), so gradients flow back into the MLP while
//    the search only reads the grid. freeze() turns it into a fixed grid.
//  - FrozenSkinningField: a fixed weight grid (inference, preset weights).
//  - CallerGridSkinningField: a grid the caller computes, with its autograd
//    graph, and sets before each search (the Python module's learned grids: a
//    softmax of a voxel parameter, or the caller's MLP at the voxel centres).
#include <memory>

#include "fskin/fields/skinning_field.h"

namespace fskin {

class FrozenSkinningField : public GridSkinningField {
 public:
  // grid: [D, H, W, J] matching box.shape; rows >= 0, summing to 1.
  FrozenSkinningField(torch::Tensor grid, VoxelBox box);
  int64_t num_bones() const override { return grid_.size(3); }
  const VoxelBox& box() const override { return box_; }
  torch::Tensor grid_weights() override { return grid_; }

 private:
  torch::Tensor grid_;
  VoxelBox box_;
};

class CallerGridSkinningField : public GridSkinningField {
 public:
  // grid as set_grid takes it.
  CallerGridSkinningField(torch::Tensor grid, VoxelBox box);
  int64_t num_bones() const override { return grid_.size(3); }
  const VoxelBox& box() const override { return box_; }
  torch::Tensor grid_weights() override { return grid_; }
  bool requires_grad() const override { return grid_.requires_grad(); }
  // grid: [D, H, W, J] matching the box, floating point, with or without a
  // graph; the same number of bones as before. Kept as given (no copy, no
  // detach), so the roots' gradients reach whatever computed it.
  void set_grid(torch::Tensor grid);

 private:
  torch::Tensor grid_;
  VoxelBox box_;
};

class DistilledSkinningField : public GridSkinningField {
 public:
  DistilledSkinningField(std::shared_ptr<SkinningField> source, VoxelBox box);
  int64_t num_bones() const override { return source_->num_bones(); }
  const VoxelBox& box() const override { return box_; }
  torch::Tensor grid_weights() override;
  std::shared_ptr<FrozenSkinningField> freeze();
  SkinningField& source() { return *source_; }

 private:
  std::shared_ptr<SkinningField> source_;
  VoxelBox box_;
  torch::Tensor voxel_centres_;  // [D, H, W, 3]
};

}  // namespace fskin
