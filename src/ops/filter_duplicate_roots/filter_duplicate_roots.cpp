// filter_duplicate_roots as the dispatcher op fskin::filter_duplicate_roots
// (schema, CPU / CUDA kernels; ops/common/dispatcher.h).
#include "fskin/ops/filter_duplicate_roots.h"

#include <torch/library.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/filter_duplicate_roots/filter_duplicate_roots_kernel.h"
#include "ops/common/dispatcher.h"
#include "ops/common/run_on_device.h"

namespace fskin {
namespace {

using FilterSignature = torch::Tensor(const torch::Tensor&, const torch::Tensor&, double);

// The CPU and CUDA keys' kernel (one function: run_on_device picks the launch).
// Not differentiable: it returns a mask.
torch::Tensor filter_duplicate_roots_kernel(const torch::Tensor& x_canonical, const torch::Tensor& valid,
                                            double distance) {
  expect_shape(x_canonical, {-1, -1, -1, 3}, "filter_duplicate_roots: x_canonical");
  expect_shape(valid, {x_canonical.size(0), x_canonical.size(1), x_canonical.size(2)},
               "filter_duplicate_roots: valid");
  FSKIN_CHECK(valid.scalar_type() == torch::kBool, "filter_duplicate_roots: valid must be bool");
  FSKIN_CHECK(distance >= 0, "filter_duplicate_roots: distance {} must be >= 0", distance);
  FSKIN_CHECK(valid.device() == x_canonical.device(), "filter_duplicate_roots: inputs on different devices");
  const auto x = x_canonical.detach().contiguous();
  auto out = valid.clone().contiguous();
  const int64_t points = x.size(0) * x.size(1);
  if (points == 0 || x.size(2) < 2) return out;
  AT_DISPATCH_FLOATING_TYPES(x.scalar_type(), "filter_duplicate_roots", [&] {
    const kernels::FilterLaunch<scalar_t> launch{x.data_ptr<scalar_t>(), out.data_ptr<bool>(), points,
                                                 static_cast<int>(x.size(2)),
                                                 static_cast<scalar_t>(distance * distance)};
    run_on_device(
        x, "filter_duplicate_roots", [&] { kernels::filter_duplicate_roots_cpu(launch); },
        [&](void* stream) { kernels::filter_duplicate_roots_cuda(launch, stream); });
  });
  return out;
}

}  // namespace

TORCH_LIBRARY_FRAGMENT(fskin, m) {
  m.def("filter_duplicate_roots(Tensor x_canonical, Tensor valid, float distance=0.0001) -> Tensor");
}

TORCH_LIBRARY_IMPL(fskin, CPU, m) { m.impl("filter_duplicate_roots", TORCH_FN(filter_duplicate_roots_kernel)); }

#ifdef FSKIN_WITH_CUDA
TORCH_LIBRARY_IMPL(fskin, CUDA, m) { m.impl("filter_duplicate_roots", TORCH_FN(filter_duplicate_roots_kernel)); }
#endif

torch::Tensor filter_duplicate_roots(const torch::Tensor& x_canonical, const torch::Tensor& valid,
                                     double distance) {
  static const auto op = fskin_operator<FilterSignature>("fskin::filter_duplicate_roots");
  return op.call(x_canonical, valid, distance);
}

}  // namespace fskin
