#pragma once
// Intra-op threads matched to the cores the rest of the machine leaves free.
//
// A training step is many short parallel regions; with one OpenMP thread per
// core, each region's barrier waits for the thread whose core another process
// holds, so a second training or a compiler made fskin much slower than its
// fair share (docs/benchmarks.md, "Training next to other processes"). Long
// loops call follow_free_cores() between iterations; at most once per
// kFreeCoreWindowSeconds it measures how many cores other processes (and the
// hypervisor's steal) kept busy over the last window, from /proc/stat and this
// process's own CPU time, and sets at::set_num_threads to the cores left.
#include <optional>

namespace fskin {

constexpr double kFreeCoreWindowSeconds = 1.0;

// CPU time of the whole machine and of this process at one moment.
struct CpuTimes {
  double wall_s = 0;          // steady clock
  double machine_busy_s = 0;  // all cores: user, nice, system, irq, softirq, steal
  double self_s = 0;          // this process, all its threads, user + system
  int cores = 0;              // cores /proc/stat lists
};

// Now; nullopt where /proc/stat cannot be read (not Linux, a sandbox).
std::optional<CpuTimes> read_cpu_times();

// Cores other processes kept busy on average between two samples (>= 0).
double cores_used_by_others(const CpuTimes& before, const CpuTimes& after);

// Threads to run with `free_cores` free, from `current`, in 1..max_threads:
// fewer once less than current - 0.5 cores are free (rounded to nearest),
// more once more than current + 0.75 are (rounded down from free + 0.25). The
// band keeps the count from flapping when a neighbour uses part of a core.
int threads_for_free_cores(double free_cores, int current, int max_threads);

// Process-wide and off until enabled: the CLI enables it with the machine's
// core count unless --threads is given (then the count is fixed). Enabling
// sets max_threads threads now; disabling leaves the current count.
void follow_free_cores_up_to(int max_threads);
void stop_following_free_cores();
bool following_free_cores();

// Between iterations of a long loop: a no-op unless enabled; measures and
// adjusts at most once per window (a few microseconds otherwise).
void follow_free_cores();

}  // namespace fskin
