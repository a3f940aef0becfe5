// The cost of calling fskin's ops through PyTorch's dispatcher
// (TORCH_LIBRARY(fskin), ops/common/dispatcher.h) against calling their CPU
// kernels directly, side by side at the sizes fskin calls them with:
// compositing one training batch of rays (forward, inputs without gradients,
// and with them: the Autograd key records the graph), and re-posing 48k
// vertices through the skinning grid.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include "fskin/ops/grid_forward_skinning.h"
#include "fskin/ops/ray_compositing.h"
#include "ops/common/dispatcher.h"
#include "ops/grid_forward_skinning/grid_forward_skinning_op.h"
#include "ops/ray_compositing/ray_compositing_op.h"

namespace {

// range(0): 0 the CPU kernel called directly, 1 through the dispatcher,
// 2 through the dispatcher with inputs that need gradients, 3 the C++ entry
// fskin::composite_rays (the dispatcher plus its checks of the inputs, delta's
// finiteness included); range(1): rays.
void BM_DispatcherCompositeRays(benchmark::State& state) {
  const int64_t path = state.range(0), rays = state.range(1), samples = 64;
  torch::manual_seed(0);
  const auto sigma = (torch::rand({rays, samples}) * 10).requires_grad_(path == 2);
  const auto rgb = torch::rand({rays, samples, 3}).requires_grad_(path == 2);
  const auto delta = torch::full({rays, samples}, 2.0 / samples);
  const auto background = torch::ones({rays, 3});
  using Signature = std::tuple<torch::Tensor, torch::Tensor>(const torch::Tensor&, const torch::Tensor&,
                                                             const torch::Tensor&, const torch::Tensor&);
  const auto op = fskin::fskin_operator<Signature>("fskin::composite_rays");
  for (auto _ : state) {
    // The operator handle, as torch.ops calls it (fskin::composite_rays adds
    // the C++ entry's finiteness check of delta, which is not the dispatcher's).
    const auto [color, opacity] = path == 0   ? fskin::composite_rays_kernel(sigma, rgb, delta, background)
                                  : path == 3 ? fskin::composite_rays(sigma, rgb, delta, background)
                                              : op.call(sigma, rgb, delta, background);
    benchmark::DoNotOptimize(color.data_ptr<float>());
  }
}
BENCHMARK(BM_DispatcherCompositeRays)
    ->ArgsProduct({{0, 1, 2, 3}, {256, 4096}})
    ->ArgNames({"path", "rays"})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime()
    ->MinTime(0.5);

// range(0): 0 direct, 1 dispatcher.
void BM_DispatcherGridForwardSkinning(benchmark::State& state) {
  const bool dispatcher = state.range(0) == 1;
  fskin::VoxelBox box;
  box.shape = {16, 64, 64};
  torch::manual_seed(0);
  auto grid = torch::zeros({1, 16, 64, 64, 12});
  grid.select(-1, 0).fill_(1);
  grid.select(-1, 5).fill_(1);
  grid.select(-1, 10).fill_(1);
  grid.add_(torch::rand_like(grid) * 0.01);
  const auto x = torch::rand({1, 48000, 3}) - 0.5;
  const std::vector<double> offset(box.offset.begin(), box.offset.end()), scale(box.scale.begin(), box.scale.end());
  for (auto _ : state) {
    const auto out = dispatcher ? fskin::grid_forward_skinning(grid, box, x)
                                : fskin::grid_forward_skinning_kernel(grid, offset, scale, x);
    benchmark::DoNotOptimize(out.data_ptr<float>());
  }
}
BENCHMARK(BM_DispatcherGridForwardSkinning)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("dispatcher")
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime()
    ->MinTime(0.5);

}  // namespace
