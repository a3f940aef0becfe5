#include "fskin/util/stopwatch.h"

#include <torch/cuda.h>

namespace fskin {

Stopwatch::Stopwatch(bool cuda) : cuda_(cuda), start_(std::chrono::steady_clock::now()) {}

double Stopwatch::elapsed() const {
  if (cuda_) torch::cuda::synchronize();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

double Stopwatch::lap() {
  const double seconds = elapsed();
  start_ = std::chrono::steady_clock::now();
  return seconds;
}

}  // namespace fskin
