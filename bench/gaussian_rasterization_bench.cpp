// Rendering a 256 x 256 frame of N Gaussians (projection + rasterisation),
// alone (range(1) 0: what a viewer pays per frame) and with the backward to
// every Gaussian parameter (range(1) 1: a training step's rendering), on the
// CPU (range(2) 0) and CUDA (range(2) 1). The Gaussians cover a body-sized
// shell 2.5 units in front of the camera, sized so that neighbours overlap,
// as a trained avatar's do: cost grows with N and with the pixels they cover.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <cmath>

#include "bench_device.h"
#include "fskin/gaussians/gaussian_projection.h"
#include "fskin/ops/gaussian_rasterization.h"

namespace {

void BM_GaussianFrame(benchmark::State& state) {
  const int64_t n = state.range(0);
  const bool backward = state.range(1) == 1;
  const auto chosen = fskin::bench::benchmark_device(state, state.range(2) == 1);
  if (!chosen) return;
  const torch::Device device = *chosen;
  torch::manual_seed(0);
  // Points on a sphere of radius 0.5 (surface area pi): spacing sqrt(pi / N).
  auto directions = torch::randn({n, 3});
  directions = directions / directions.norm(2, 1, true);
  const auto means = (0.5 * directions + torch::tensor({0.0f, 0.0f, 2.5f})).to(device).requires_grad_(backward);
  const double spacing = std::sqrt(M_PI / static_cast<double>(n));
  const auto scales = torch::full({n, 3}, static_cast<float>(spacing)).to(device);
  const auto rotations = torch::randn({n, 4}).to(device);
  const auto colors = torch::rand({n, 3}).to(device).requires_grad_(backward);
  const auto opacities = torch::full({n}, 0.8f).to(device).requires_grad_(backward);
  const auto background = torch::ones({3}).to(device);
  fskin::PinholeCamera camera;
  camera.width = camera.height = 256;
  camera.intrinsic << 300, 0, 127.5, 0, 300, 127.5, 0, 0, 1;
  for (auto _ : state) {
    torch::AutoGradMode grad_mode(backward);
    const auto covariances = fskin::gaussian_covariances(scales, rotations);
    const auto p = fskin::project_gaussians(means, covariances, camera);
    const auto [image, alpha] =
        fskin::rasterize_gaussians(p.means2d, p.conics, colors, opacities, p.depths, p.radii, background, 256, 256);
    if (backward) (image.sum() + alpha.sum()).backward();
    if (device.is_cuda()) torch::cuda::synchronize();
    benchmark::DoNotOptimize(image.data_ptr<float>());
  }
  state.counters["frames/s"] = benchmark::Counter(1.0, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_GaussianFrame)
    ->ArgsProduct({{10000, 100000, 500000}, {0, 1}, {0, 1}})
    ->ArgNames({"gaussians", "backward", "cuda"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

}  // namespace
