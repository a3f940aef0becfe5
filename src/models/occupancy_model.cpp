#include "fskin/training/occupancy_model.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {

torch::Tensor pose_condition(const torch::Tensor& pose) {
  expect_shape(pose, {-1, -1, 3}, "pose_condition: pose");
  return pose.slice(1, 1).flatten(1) / M_PI;
}

torch::Tensor to_root_frame(const torch::Tensor& points, const torch::Tensor& bones) {
  expect_shape(points, {-1, -1, 3}, "to_root_frame: points");
  expect_shape(bones, {points.size(0), -1, 4, 4}, "to_root_frame: bones");
  return transform_points(invert_transforms(bones.select(1, 0).to(points.dtype())).unsqueeze(1), points);
}

torch::Tensor OccupancyModel::bootstrap_loss(const BootstrapInputs&) { return {}; }

torch::Tensor OccupancyModel::canonical_logits(const torch::Tensor&, const torch::Tensor&) {
  fail("this method has no canonical shape (it predicts occupancy in posed space only)");
}

torch::Tensor OccupancyModel::repose(const torch::Tensor&, const torch::Tensor&) {
  fail("this method has no map from canonical to posed space (it cannot re-pose a canonical mesh)");
}

std::vector<OccupancyModel::ParameterGroup> OccupancyModel::parameter_groups(double learning_rate) {
  return {{parameters(), learning_rate}};
}

}  // namespace fskin
