#include "fskin/core/tensor_checks.h"

#include <fmt/format.h>
#include <torch/torch.h>

#include "fskin/core/error.h"

namespace fskin {

std::string shape_string(at::IntArrayRef shape) {
  std::string out = "[";
  for (size_t i = 0; i < shape.size(); ++i) {
    if (i) out += ", ";
    out += shape[i] < 0 ? std::string("*") : std::to_string(shape[i]);
  }
  return out + "]";
}

void expect_shape(const torch::Tensor& tensor, std::initializer_list<int64_t> expected,
                  const std::string& name) {
  FSKIN_CHECK(tensor.defined(), "{}: tensor is undefined, expected shape {}", name,
              shape_string(std::vector<int64_t>(expected)));
  bool ok = tensor.dim() == static_cast<int64_t>(expected.size());
  if (ok) {
    int64_t i = 0;
    for (int64_t e : expected) {
      if (e >= 0 && tensor.size(i) != e) ok = false;
      ++i;
    }
  }
  FSKIN_CHECK(ok, "{}: expected shape {}, got {}", name,
              shape_string(std::vector<int64_t>(expected)), shape_string(tensor.sizes()));
}

void expect_finite(const torch::Tensor& tensor, const std::string& name) {
  if (!tensor.is_floating_point() || tensor.numel() == 0) return;
  const auto finite = torch::isfinite(tensor.detach());
  if (finite.all().item<bool>()) return;
  const int64_t bad = (~finite).sum().item<int64_t>();
  const auto first = (~finite).flatten().nonzero()[0][0].item<int64_t>();
  fail("{}: {} non-finite value(s) (NaN or inf), first at flat index {}", name, bad, first);
}

void expect_finite_on_cpu(const torch::Tensor& tensor, const std::string& name) {
  if (tensor.is_cpu()) expect_finite(tensor, name);
}

void expect_floating(const torch::Tensor& tensor, const std::string& name) {
  FSKIN_CHECK(tensor.is_floating_point(), "{}: expected a floating-point tensor, got {}", name,
              std::string(c10::toString(tensor.scalar_type())));
}

}  // namespace fskin
