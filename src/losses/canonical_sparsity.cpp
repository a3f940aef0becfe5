#include "fskin/losses/canonical_sparsity.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

torch::Tensor canonical_sparsity_loss(OccupancyModel& model, const Box& box, const torch::Tensor& pose,
                                      int64_t points_per_frame, at::Generator& generator) {
  FSKIN_CHECK(model.has_canonical_shape(), "canonical sparsity: the method has no canonical shape");
  FSKIN_CHECK(points_per_frame >= 1, "canonical sparsity: points_per_frame must be >= 1, got {}", points_per_frame);
  expect_shape(pose, {-1, -1, 3}, "canonical sparsity: pose");
  const auto options = torch::TensorOptions().dtype(torch::kFloat32);
  const auto lo = torch::tensor({box.min[0], box.min[1], box.min[2]}, options);
  const auto hi = torch::tensor({box.max[0], box.max[1], box.max[2]}, options);
  const auto unit = at::rand({pose.size(0), points_per_frame, 3}, generator, c10::kFloat);
  const auto points = (lo + unit * (hi - lo)).to(pose.device());
  const auto logits = model.canonical_logits(points, pose);
  return torch::binary_cross_entropy_with_logits(logits, torch::zeros_like(logits));
}

}  // namespace fskin
