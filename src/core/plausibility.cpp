#include "fskin/core/plausibility.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

void expect_plausible(const torch::Tensor& tensor, const std::string& name) {
  expect_floating(tensor, name);
  expect_finite(tensor, name);
  if (tensor.numel() == 0) return;
  const double largest = tensor.abs().max().item<double>();
  FSKIN_CHECK(largest <= kMaxPlausibleCoordinate, "{}: implausible magnitude {:g} (|value| <= {:g} expected)", name,
              largest, kMaxPlausibleCoordinate);
}

}  // namespace fskin
