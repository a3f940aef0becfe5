#include "fskin/models/pose_condition.h"

#include <torch/torch.h>

#include <cmath>

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

}  // namespace fskin
