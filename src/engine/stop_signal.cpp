#include "fskin/engine/stop_signal.h"

#include <atomic>
#include <csignal>
#include <cstdlib>

namespace fskin {

namespace {
std::atomic<int> g_stop_count{0};
void (*g_prev_int)(int) = SIG_DFL;
void (*g_prev_term)(int) = SIG_DFL;

extern "C" void on_stop_signal(int) {
  if (g_stop_count.fetch_add(1) >= 1) std::_Exit(130);  // second Ctrl-C: leave now
}
}  // namespace

StopSignal::StopSignal() {
  g_stop_count = 0;
  g_prev_int = std::signal(SIGINT, on_stop_signal);
  g_prev_term = std::signal(SIGTERM, on_stop_signal);
}

StopSignal::~StopSignal() {
  std::signal(SIGINT, g_prev_int);
  std::signal(SIGTERM, g_prev_term);
}

bool StopSignal::requested() const { return g_stop_count.load() > 0; }

void StopSignal::request() { g_stop_count.fetch_add(1); }

}  // namespace fskin
