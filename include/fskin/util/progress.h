#pragma once
// A terminal progress bar for long work (dataset builds, training, meshing).
// Draws on stderr, redraws at most ~10 times per second, and prints plain
// periodic lines instead when stderr is not a terminal (CI logs).
#include <chrono>
#include <cstdint>
#include <string>

namespace fskin {

class ProgressBar {
 public:
  ProgressBar(std::string label, int64_t total, bool enabled = true);
  ~ProgressBar();  // finishes the line
  // Advance by `n` and optionally set a status suffix such as "loss 0.12".
  void advance(int64_t n = 1, const std::string& status = {});
  void finish();

 private:
  void draw(bool force);
  std::string label_;
  int64_t total_, done_ = 0;
  bool enabled_, tty_, finished_ = false;
  std::string status_;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace fskin
