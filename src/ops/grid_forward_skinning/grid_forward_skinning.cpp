// grid_forward_skinning as the dispatcher op fskin::grid_forward_skinning
// (schema, CPU / CUDA kernels; ops/common/dispatcher.h): validates the inputs,
// fills the raw launch arguments and dispatches on dtype.
#include "fskin/ops/grid_forward_skinning.h"

#include <torch/library.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/grid_forward_skinning/grid_forward_skinning_kernel.h"
#include "ops/common/box_arguments.h"
#include "ops/common/dispatcher.h"
#include "ops/grid_forward_skinning/grid_forward_skinning_op.h"
#include "ops/common/run_on_device.h"
#include "ops/common/transform_grid_view.h"

namespace fskin {

namespace {

using SkinningSignature = torch::Tensor(const torch::Tensor&, c10::ArrayRef<double>, c10::ArrayRef<double>,
                                        const torch::Tensor&);

}  // namespace

// The CPU and CUDA keys' kernel (one function: the devices share the per-point
// core and launch arguments; run_on_device picks the launch). No Autograd
// kernel: the op is not differentiable, and the deformers call it only where
// gradients are off.
torch::Tensor grid_forward_skinning_kernel(const torch::Tensor& transform_grid, c10::ArrayRef<double> box_offset,
                                           c10::ArrayRef<double> box_scale, const torch::Tensor& x_canonical) {
  const auto box = box_from_arguments(box_offset, box_scale, transform_grid, "grid_forward_skinning");
  expect_shape(x_canonical, {-1, -1, 3}, "grid_forward_skinning: x_canonical");
  const int64_t B = x_canonical.size(0), N = x_canonical.size(1);
  expect_shape(transform_grid, {B, box.shape.depth, box.shape.height, box.shape.width, kernels::kChannels},
               "grid_forward_skinning: transform_grid");
  const auto dtype = x_canonical.scalar_type();
  FSKIN_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64,
              "grid_forward_skinning: x_canonical must be float32 or float64");
  FSKIN_CHECK(transform_grid.scalar_type() == dtype,
              "grid_forward_skinning: transform_grid and x_canonical must share one dtype");
  FSKIN_CHECK(transform_grid.device() == x_canonical.device(),
              "grid_forward_skinning: transform_grid and x_canonical must be on one device");
  const auto grid = transform_grid.detach().contiguous();
  const auto x = x_canonical.detach().contiguous();
  auto out = torch::empty_like(x);
  if (B * N == 0) return out;
  AT_DISPATCH_FLOATING_TYPES(dtype, "grid_forward_skinning", [&] {
    grid_skinning::SkinningLaunch<scalar_t> a{};
    a.grid = transform_grid_view<scalar_t>(grid, box);
    a.grid_frame_stride = grid[0].numel();
    a.x = x.data_ptr<scalar_t>();
    a.batch = B;
    a.points = N;
    a.out = out.data_ptr<scalar_t>();
    run_on_device(
        x, "grid_forward_skinning", [&] { grid_skinning::grid_forward_skinning_cpu(a); },
        [&](void* stream) { grid_skinning::grid_forward_skinning_cuda(a, stream); });
  });
  return out;
}

TORCH_LIBRARY_FRAGMENT(fskin, m) {
  m.def(
      "grid_forward_skinning(Tensor transform_grid, float[] box_offset, float[] box_scale, Tensor x_canonical) "
      "-> Tensor");
}

TORCH_LIBRARY_IMPL(fskin, CPU, m) { m.impl("grid_forward_skinning", TORCH_FN(grid_forward_skinning_kernel)); }

#ifdef FSKIN_WITH_CUDA
TORCH_LIBRARY_IMPL(fskin, CUDA, m) { m.impl("grid_forward_skinning", TORCH_FN(grid_forward_skinning_kernel)); }
#endif

torch::Tensor grid_forward_skinning(const torch::Tensor& transform_grid, const VoxelBox& box,
                                    const torch::Tensor& x_canonical) {
  expect_grid_over_box(transform_grid, box, "grid_forward_skinning");
  static const auto op = fskin_operator<SkinningSignature>("fskin::grid_forward_skinning");
  return op.call(transform_grid, box_offset_argument(box), box_scale_argument(box), x_canonical);
}

}  // namespace fskin
