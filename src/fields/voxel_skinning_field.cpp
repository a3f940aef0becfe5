#include "fskin/fields/voxel_skinning_field.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

namespace {
// Skinning weights blend bones: a negative one turns a bone's transform
// around, and the search then finds no root near the surface. Checked on the
// host only (a device check would synchronise every search).
void expect_non_negative_weights_on_cpu(const torch::Tensor& grid, const std::string& name) {
  if (!grid.is_cpu() || grid.numel() == 0) return;
  const auto smallest = grid.detach().min().item<double>();
  if (smallest >= 0) return;
  const auto flat = grid.detach().reshape({-1}).argmin().item<int64_t>();
  const int64_t bones = grid.size(3), width = grid.size(2), height = grid.size(1);
  const int64_t bone = flat % bones, voxel = flat / bones;
  fail("{}: skinning weights must be >= 0 (a blend of bones, e.g. a softmax over the last axis); got {} at voxel "
       "(d, h, w) = ({}, {}, {}), bone {}",
       name, smallest, voxel / (width * height), (voxel / width) % height, voxel % width, bone);
}
}  // namespace

FrozenSkinningField::FrozenSkinningField(torch::Tensor grid, VoxelBox box) : box_(box) {
  box_.validate("FrozenSkinningField");
  expect_shape(grid, {box_.shape.depth, box_.shape.height, box_.shape.width, -1}, "FrozenSkinningField: grid");
  FSKIN_CHECK(grid.size(3) >= 1, "FrozenSkinningField: grid has no bones");
  expect_floating(grid, "FrozenSkinningField: grid");
  expect_finite(grid, "FrozenSkinningField: grid");
  expect_non_negative_weights_on_cpu(grid, "FrozenSkinningField: grid");
  grid_ = register_buffer("grid", grid.detach().contiguous());
}

CallerGridSkinningField::CallerGridSkinningField(torch::Tensor grid, VoxelBox box) : box_(box) {
  box_.validate("skinning grid");
  set_grid(std::move(grid));
}

void CallerGridSkinningField::set_grid(torch::Tensor grid) {
  expect_shape(grid, {box_.shape.depth, box_.shape.height, box_.shape.width, -1}, "skinning grid");
  FSKIN_CHECK(grid.size(3) >= 1, "skinning grid: no bones");
  FSKIN_CHECK(!grid_.defined() || grid.size(3) == grid_.size(3), "skinning grid: {} bones, the deformer has {}",
              grid.size(3), grid_.size(3));
  expect_floating(grid, "skinning grid");
  expect_finite_on_cpu(grid, "skinning grid");
  expect_non_negative_weights_on_cpu(grid, "skinning grid");
  grid_ = std::move(grid);
}

DistilledSkinningField::DistilledSkinningField(std::shared_ptr<SkinningField> source, VoxelBox box)
    : source_(std::move(source)), box_(box) {
  FSKIN_CHECK(source_ != nullptr, "DistilledSkinningField: no source field");
  box_.validate("DistilledSkinningField");
  register_module("source", source_);
  voxel_centres_ = register_buffer("voxel_centres", box_.voxel_centres(torch::kFloat32));
}

torch::Tensor DistilledSkinningField::grid_weights() {
  const auto params = source_->parameters();
  const auto dtype = params.empty() ? voxel_centres_.scalar_type() : params[0].scalar_type();
  return source_->weights(voxel_centres_.to(dtype));
}

std::shared_ptr<FrozenSkinningField> DistilledSkinningField::freeze() {
  torch::NoGradGuard no_grad;
  return std::make_shared<FrozenSkinningField>(grid_weights(), box_);
}

}  // namespace fskin
