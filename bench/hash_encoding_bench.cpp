// The hash encoding (instant-NGP sizes: 16 levels x 2 features, 2^19 rows,
// 16 to ~4.4k cells): forward + backward to the table of 1M points, the fused
// op against the same encoding in LibTorch operations, on the CPU (range(1)
// 0) and, where a GPU exists, on CUDA (range(1) 1).
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <thread>

#include "bench_device.h"
#include "fskin/ops/hash_encoding.h"

namespace {

// range(0): 1 fused, 0 LibTorch reference; range(1): 0 CPU, 1 CUDA.
void BM_HashEncodingForwardBackward(benchmark::State& state) {
  const bool fused = state.range(0) == 1;
  const bool cuda = state.range(1) == 1;
  const auto chosen = fskin::bench::benchmark_device(state, cuda);
  if (!chosen) return;
  const torch::Device device = *chosen;
  fskin::HashEncodingOptions o;  // L 16, F 2, T 19, N_min 16, b 1.5
  const int64_t n = 1 << 20;
  torch::manual_seed(0);
  const auto positions = torch::rand({n, 3}).to(device);
  const auto table = fskin::hash_encoding_table(o, torch::TensorOptions().device(device)).requires_grad_(true);
  const auto weights = torch::randn({n, o.output_dim()}).to(device);
  for (auto _ : state) {
    table.mutable_grad() = torch::Tensor();
    const auto features = fused ? fskin::hash_encoding(positions, table, o)
                                : fskin::hash_encoding_reference(positions, table, o);
    (features * weights).sum().backward();
    if (cuda) torch::cuda::synchronize();
    benchmark::DoNotOptimize(table.grad().data_ptr<float>());
  }
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_HashEncodingForwardBackward)
    ->ArgsProduct({{1, 0}, {0, 1}})
    ->ArgNames({"fused", "cuda"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

// The forward pass alone (inference: rendering a trained avatar); range(0) as above.
void BM_HashEncodingForward(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  torch::NoGradGuard no_grad;
  fskin::HashEncodingOptions o;
  const int64_t n = 1 << 20;
  torch::manual_seed(0);
  const auto positions = torch::rand({n, 3});
  const auto table = fskin::hash_encoding_table(o);
  for (auto _ : state) {
    const auto features = state.range(0) == 1 ? fskin::hash_encoding(positions, table, o)
                                              : fskin::hash_encoding_reference(positions, table, o);
    benchmark::DoNotOptimize(features.data_ptr<float>());
  }
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_HashEncodingForward)->Arg(1)->Arg(0)->ArgName("fused")->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
