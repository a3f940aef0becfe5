#pragma once
// Wall-clock stage timing. With `cuda` set and CUDA timing on, every reading
// first waits for queued GPU work, so a stage is charged for the kernels it
// launched. CUDA timing is off by default: each wait is a host
// synchronisation that drains the GPU's queue between stages, so without it a
// CUDA stage's time is the host's time to queue its kernels. `fskin bench`
// and fskin_bench turn it on.
#include <chrono>

namespace fskin {

void set_cuda_timing(bool wait_for_device);
bool cuda_timing();

class Stopwatch {
 public:
  explicit Stopwatch(bool cuda = false);
  double elapsed() const;  // seconds since construction or the last lap()
  double lap();            // elapsed(), then restart

 private:
  bool cuda_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace fskin
