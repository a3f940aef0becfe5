#include "fskin/networks/input_normalization.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

InputNormalization InputNormalization::around(const torch::Tensor& points) {
  expect_shape(points, {-1, 3}, "InputNormalization::around: points");
  FSKIN_CHECK(points.size(0) > 0, "InputNormalization::around: no points");
  expect_finite(points, "InputNormalization::around: points");
  const auto p = points.detach().to(torch::kCPU, torch::kFloat64);
  const auto lo = std::get<0>(p.min(0)), hi = std::get<0>(p.max(0));
  const double extent = (hi - lo).max().item<double>();
  FSKIN_CHECK(extent > 0, "InputNormalization::around: the points span no volume");
  InputNormalization n;
  for (int a = 0; a < 3; ++a) n.centre[a] = (lo[a].item<double>() + hi[a].item<double>()) / 2;
  n.scale = 2.0 / extent;
  return n;
}

torch::Tensor InputNormalization::apply(const torch::Tensor& x) const {
  FSKIN_CHECK(x.dim() >= 1 && x.size(-1) == 3, "InputNormalization: points must be [..., 3], got {}",
              shape_string(x.sizes()));
  if (scale == 1.0 && centre == std::array<double, 3>{0.0, 0.0, 0.0}) return x;
  const auto c = torch::tensor({centre[0], centre[1], centre[2]}, x.options());
  return (x - c) * scale;
}

torch::Tensor InputNormalization::unapply(const torch::Tensor& u) const {
  FSKIN_CHECK(u.dim() >= 1 && u.size(-1) == 3, "InputNormalization: points must be [..., 3], got {}",
              shape_string(u.sizes()));
  if (scale == 1.0 && centre == std::array<double, 3>{0.0, 0.0, 0.0}) return u;
  return u / scale + torch::tensor({centre[0], centre[1], centre[2]}, u.options());
}

}  // namespace fskin
