#include "fskin/util/stopwatch.h"

#include <torch/cuda.h>

#include <atomic>

namespace fskin {

namespace {
std::atomic<bool> g_cuda_timing{false};
}  // namespace

void set_cuda_timing(bool wait_for_device) { g_cuda_timing = wait_for_device; }
bool cuda_timing() { return g_cuda_timing; }

Stopwatch::Stopwatch(bool cuda) : cuda_(cuda), start_(std::chrono::steady_clock::now()) {}

double Stopwatch::elapsed() const {
  if (cuda_ && g_cuda_timing) torch::cuda::synchronize();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

double Stopwatch::lap() {
  const double seconds = elapsed();
  start_ = std::chrono::steady_clock::now();
  return seconds;
}

}  // namespace fskin
