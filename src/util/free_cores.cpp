#include "fskin/util/free_cores.h"

#include <ATen/Parallel.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <mutex>

namespace fskin {

namespace {

double seconds_of(const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); }

struct Follower {
  std::mutex mutex;
  bool enabled = false;
  int max_threads = 1;
  std::optional<CpuTimes> window_start;
  int64_t iterations = 0;  // calls of follow_free_cores in this window
  std::map<int, ThreadTiming> timings;
};

Follower& follower() {
  static Follower f;
  return f;
}

}  // namespace

std::optional<CpuTimes> read_cpu_times() {
  // /proc/stat by hand: its first line is the machine's total, then one
  // "cpuN" line per core (proc(5)); no library reads it.
  FILE* file = std::fopen("/proc/stat", "r");
  if (file == nullptr) return std::nullopt;
  CpuTimes t;
  char line[512];
  bool have_total = false;
  while (std::fgets(line, sizeof line, file) != nullptr) {
    if (std::strncmp(line, "cpu", 3) != 0) break;
    if (line[3] == ' ') {
      unsigned long long user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
      if (std::sscanf(line + 3, "%llu %llu %llu %llu %llu %llu %llu %llu", &user, &nice, &system, &idle, &iowait,
                      &irq, &softirq, &steal) < 4)
        break;
      // guest time is already inside user and nice.
      const double ticks_per_s = static_cast<double>(sysconf(_SC_CLK_TCK));
      t.machine_busy_s = static_cast<double>(user + nice + system + irq + softirq + steal) / ticks_per_s;
      have_total = true;
    } else {
      ++t.cores;
    }
  }
  std::fclose(file);
  if (!have_total || t.cores == 0) return std::nullopt;
  rusage self{};
  if (getrusage(RUSAGE_SELF, &self) != 0) return std::nullopt;
  t.self_s = seconds_of(self.ru_utime) + seconds_of(self.ru_stime);
  t.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  return t;
}

double cores_used_by_others(const CpuTimes& before, const CpuTimes& after) {
  const double wall = after.wall_s - before.wall_s;
  if (wall <= 0) return 0;
  const double others = (after.machine_busy_s - before.machine_busy_s) - (after.self_s - before.self_s);
  return std::max(0.0, others / wall);
}

int threads_for_free_cores(double free_cores, int current, int max_threads) {
  max_threads = std::max(1, max_threads);
  int threads = std::clamp(current, 1, max_threads);
  if (free_cores < threads - 0.5) threads = static_cast<int>(std::floor(free_cores + 0.5));
  else if (free_cores > threads + 0.75) threads = static_cast<int>(std::floor(free_cores + 0.25));
  return std::clamp(threads, 1, max_threads);
}

int faster_thread_count(int proposed, const std::map<int, ThreadTiming>& timings, double others_now, double wall_now) {
  const auto trusted = [&](const ThreadTiming& t) {
    return wall_now - t.wall_s <= kThreadTimingMemorySeconds &&
           std::abs(t.others - others_now) < kThreadTimingSameLoadCores;
  };
  const auto proposal = timings.find(proposed);
  if (proposal == timings.end() || !trusted(proposal->second)) return proposed;
  int fastest = proposed;
  double fastest_s = proposal->second.seconds_per_iteration * (1 - kThreadTimingTolerance);
  for (const auto& [threads, timing] : timings) {
    if (threads != proposed && trusted(timing) && timing.seconds_per_iteration < fastest_s) {
      fastest = threads;
      fastest_s = timing.seconds_per_iteration;
    }
  }
  return fastest;
}

void follow_free_cores_up_to(int max_threads) {
  auto& f = follower();
  const std::lock_guard<std::mutex> lock(f.mutex);
  f.max_threads = std::max(1, max_threads);
  f.enabled = f.max_threads > 1;
  // The first call opens the first window: the time before it (loading data)
  // is no iteration's.
  f.window_start.reset();
  f.iterations = 0;
  f.timings.clear();
  at::set_num_threads(f.max_threads);
}

void stop_following_free_cores() {
  auto& f = follower();
  const std::lock_guard<std::mutex> lock(f.mutex);
  f.enabled = false;
}

bool following_free_cores() {
  auto& f = follower();
  const std::lock_guard<std::mutex> lock(f.mutex);
  return f.enabled;
}

void follow_free_cores() {
  auto& f = follower();
  const std::lock_guard<std::mutex> lock(f.mutex);
  if (!f.enabled) return;
  ++f.iterations;
  // The clock first: /proc/stat is read once per window, not per call.
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  if (f.window_start && wall - f.window_start->wall_s < kFreeCoreWindowSeconds) return;
  const auto now = read_cpu_times();
  if (!now) return;
  if (f.window_start) {
    const double others = cores_used_by_others(*f.window_start, *now);
    const int current = at::get_num_threads();
    f.timings[current] = {(now->wall_s - f.window_start->wall_s) / static_cast<double>(f.iterations), others,
                          now->wall_s};
    const int proposed = threads_for_free_cores(now->cores - others, current, std::min(f.max_threads, now->cores));
    const int threads = faster_thread_count(proposed, f.timings, others, now->wall_s);
    if (threads != current) at::set_num_threads(threads);
  }
  f.window_start = now;
  f.iterations = 0;
}

}  // namespace fskin
