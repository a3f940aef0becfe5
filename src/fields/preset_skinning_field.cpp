#include "fskin/fields/preset_skinning_field.h"

#include <torch/torch.h>

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/geometry/nearest_vertex.h"

namespace fskin {

std::shared_ptr<FrozenSkinningField> diffuse_weights_to_grid(const torch::Tensor& vertices,
                                                             const torch::Tensor& weights, const VoxelBox& box,
                                                             const WeightDiffusionOptions& options) {
  expect_shape(vertices, {-1, 3}, "diffuse_weights_to_grid: vertices");
  expect_shape(weights, {vertices.size(0), -1}, "diffuse_weights_to_grid: weights");
  FSKIN_CHECK(vertices.size(0) > 0, "diffuse_weights_to_grid: no vertices");
  FSKIN_CHECK(options.smoothing_iterations >= 0, "diffuse_weights_to_grid: smoothing_iterations must be >= 0");
  box.validate("diffuse_weights_to_grid");
  torch::NoGradGuard no_grad;
  const auto v = vertices.detach().to(torch::kFloat32);
  const auto w = weights.detach().to(torch::kFloat32);
  const auto centres = box.voxel_centres(torch::kFloat32).reshape({-1, 3});
  // Nearest vertex per voxel.
  const auto [nearest, distance] = nearest_vertices(centres, v);
  const GridShape& shape = box.shape;
  auto grid = w.index_select(0, nearest).reshape({shape.depth, shape.height, shape.width, w.size(1)});
  // Voxel diagonal in canonical units (the smallest voxel side bounds the band).
  double diagonal = 0;
  const int64_t sizes[3] = {shape.width, shape.height, shape.depth};
  for (int a = 0; a < 3; ++a) {
    const double side = 2.0 / box.scale[a] / static_cast<double>(sizes[a] - 1);
    diagonal += side * side;
  }
  diagonal = std::sqrt(diagonal);
  const auto anchored = (distance <= options.surface_band * diagonal)
                            .reshape({shape.depth, shape.height, shape.width, 1});
  const auto anchor_values = grid.clone();
  // Diffusion: 3x3x3 box blur with replicated borders, anchors reset each pass.
  for (int it = 0; it < options.smoothing_iterations; ++it) {
    auto x = grid.permute({3, 0, 1, 2}).unsqueeze(0);  // [1, J, D, H, W]
    x = torch::replication_pad3d(x, {1, 1, 1, 1, 1, 1});
    x = torch::avg_pool3d(x, 3, 1);
    grid = torch::where(anchored, anchor_values, x.squeeze(0).permute({1, 2, 3, 0}));
  }
  grid = grid.clamp_min(0);
  grid = grid / grid.sum(-1, true).clamp_min(1e-12);
  return std::make_shared<FrozenSkinningField>(grid.contiguous(), box);
}

}  // namespace fskin
