#include "fskin/fields/skinning_field.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

bool SkinningField::requires_grad() const {
  for (const auto& p : parameters())
    if (p.requires_grad()) return true;
  return false;
}

torch::Tensor GridSkinningField::weights(const torch::Tensor& x_canonical) {
  FSKIN_CHECK(x_canonical.dim() >= 1 && x_canonical.size(-1) == 3,
              "GridSkinningField::weights: points must be [..., 3], got {}", shape_string(x_canonical.sizes()));
  const auto grid = grid_weights();
  auto out_shape = x_canonical.sizes().vec();
  out_shape.back() = grid.size(3);
  return sample_voxels(grid, box(), x_canonical.reshape({-1, 3})).reshape(out_shape);
}

}  // namespace fskin
