#pragma once
// Wall-clock stage timing. With `cuda` set, every reading first waits for
// queued GPU work, so a stage is charged for the kernels it launched.
#include <chrono>

namespace fskin {

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
