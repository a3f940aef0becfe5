// grid_forward_skinning: validates the inputs, fills the raw launch arguments
// and dispatches on device and dtype.
#include "fskin/ops/grid_forward_skinning.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/grid_forward_skinning/grid_forward_skinning_kernel.h"
#include "ops/common/run_on_device.h"
#include "ops/common/transform_grid_view.h"

namespace fskin {

torch::Tensor grid_forward_skinning(const torch::Tensor& transform_grid, const VoxelBox& box,
                                    const torch::Tensor& x_canonical) {
  box.validate("grid_forward_skinning");
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

}  // namespace fskin
