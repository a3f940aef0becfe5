#pragma once
// The device a benchmark case runs on (its `cuda` argument): all CPU threads
// for a CPU case; a CUDA case without a GPU is reported as skipped.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <optional>
#include <thread>

namespace fskin::bench {

inline std::optional<torch::Device> benchmark_device(benchmark::State& state, bool cuda) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  if (!cuda) return torch::Device(torch::kCPU);
  if (!torch::cuda::is_available()) {
    state.SkipWithError("no CUDA device");
    return std::nullopt;
  }
  return torch::Device(torch::kCUDA);
}

}  // namespace fskin::bench
