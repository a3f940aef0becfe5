#include "fskin/geometry/character_size.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

double character_size(const torch::Tensor& points, const char* what) {
  expect_shape(points, {-1, 3}, fmt::format("{}: points", what));
  FSKIN_CHECK(points.size(0) > 0, "{}: no points", what);
  expect_finite(points, fmt::format("{}: points", what));
  const auto p = points.detach().to(torch::kCPU, torch::kFloat64);
  const double size = (std::get<0>(p.max(0)) - std::get<0>(p.min(0))).max().item<double>();
  FSKIN_CHECK(size > 0, "{}: the points span no length (all at one place)", what);
  return size;
}

double length_unit(const torch::Tensor& points, const char* what) {
  return character_size(points, what) / kReferenceCharacterSize;
}

}  // namespace fskin
