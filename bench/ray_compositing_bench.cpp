// Ray compositing of 64k rays x 64 samples (a 256 x 256 image), forward +
// backward to density and colour: the fused op against the same compositing
// in LibTorch operations, on the CPU (range(1) 0) and CUDA (range(1) 1).
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <thread>

#include "bench_device.h"
#include "fskin/ops/ray_compositing.h"

namespace {

// range(0): 1 fused, 0 LibTorch reference; range(1): 0 CPU, 1 CUDA.
void BM_RayCompositingForwardBackward(benchmark::State& state) {
  const bool fused = state.range(0) == 1;
  const bool cuda = state.range(1) == 1;
  const auto chosen = fskin::bench::benchmark_device(state, cuda);
  if (!chosen) return;
  const torch::Device device = *chosen;
  const int64_t rays = 1 << 16, samples = 64;
  torch::manual_seed(0);
  const auto sigma = (torch::rand({rays, samples}) * 10).to(device).requires_grad_(true);
  const auto rgb = torch::rand({rays, samples, 3}).to(device).requires_grad_(true);
  const auto delta = torch::full({rays, samples}, 2.0 / samples).to(device);
  const auto background = torch::ones({rays, 3}).to(device);
  for (auto _ : state) {
    sigma.mutable_grad() = torch::Tensor();
    rgb.mutable_grad() = torch::Tensor();
    const auto [color, opacity] = fused ? fskin::composite_rays(sigma, rgb, delta, background)
                                        : fskin::composite_rays_reference(sigma, rgb, delta, background);
    (color.sum() + opacity.sum()).backward();
    if (cuda) torch::cuda::synchronize();
    benchmark::DoNotOptimize(sigma.grad().data_ptr<float>());
  }
  state.counters["rays/s"] = benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_RayCompositingForwardBackward)
    ->ArgsProduct({{1, 0}, {0, 1}})
    ->ArgNames({"fused", "cuda"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

}  // namespace
