#include "fskin/core/tensor_checks.h"

#include <fmt/format.h>
#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <atomic>

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

namespace {

// One pass over a CPU tensor's values without temporaries: torch::isfinite(t).all()
// makes several passes and a bool copy, which measured as much as the fused
// compositing kernel it guarded (bench/dispatcher_bench.cpp).
bool all_finite_cpu(const torch::Tensor& tensor) {
  const auto values = tensor.detach().contiguous();
  std::atomic<bool> finite{true};
  AT_DISPATCH_FLOATING_TYPES_AND2(at::kHalf, at::kBFloat16, values.scalar_type(), "expect_finite", [&] {
    const scalar_t* data = values.data_ptr<scalar_t>();
    at::parallel_for(0, values.numel(), 1 << 15, [&](int64_t begin, int64_t end) {
      // x * 0 is 0 for finite x and NaN for inf and NaN: a sum without branches.
      // (A double beyond float's range reads as inf here; the exact check
      // below then clears it.)
      // Eight independent sums, so the adds do not wait on each other.
      float sums[8] = {0, 0, 0, 0, 0, 0, 0, 0};
      int64_t i = begin;
      for (; i + 8 <= end; i += 8) {
        for (int k = 0; k < 8; ++k) sums[k] += static_cast<float>(data[i + k]) * 0.0f;
      }
      for (; i < end; ++i) sums[0] += static_cast<float>(data[i]) * 0.0f;
      float sum = 0;
      for (float s : sums) sum += s;
      if (sum != 0) finite = false;
    });
  });
  return finite;
}

}  // namespace

void expect_finite(const torch::Tensor& tensor, const std::string& name) {
  if (!tensor.is_floating_point() || tensor.numel() == 0) return;
  if (tensor.is_cpu() && all_finite_cpu(tensor)) return;
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
