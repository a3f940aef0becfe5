#pragma once
// Intra-op threads matched to the cores the rest of the machine leaves free.
//
// A training step is many short parallel regions; with one OpenMP thread per
// core, each region's barrier waits for the thread whose core another process
// holds, so a second training or a compiler made fskin much slower than its
// fair share (docs/benchmarks.md, "Training next to other processes"). Long
// loops call follow_free_cores() once per iteration of similar work (a
// training step, an evaluated frame); at most once per
// kFreeCoreWindowSeconds it measures how many cores other processes (and the
// hypervisor's steal) kept busy over the last window, from /proc/stat and this
// process's own CPU time, and proposes the cores left as the thread count.
// Fewer threads are not faster for every loop: work in large parallel regions
// (an avatar step of 4,096 rays) gets a larger share of a machine full of busy
// processes with more threads. So each window also records the
// seconds per iteration (calls of follow_free_cores) at its thread count, and
// a proposal measured slower than another count, under the same load, is not
// taken (faster_thread_count).
#include <map>
#include <optional>

namespace fskin {

constexpr double kFreeCoreWindowSeconds = 1.0;
// How long a window's speed at one thread count is trusted, and how far the
// other processes' load (cores) may have moved since for it to compare.
constexpr double kThreadTimingMemorySeconds = 30.0;
constexpr double kThreadTimingSameLoadCores = 0.5;
// A proposal is taken unless another count ran this much faster.
constexpr double kThreadTimingTolerance = 0.05;

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

// One window's speed at one thread count.
struct ThreadTiming {
  double seconds_per_iteration = 0;
  double others = 0;  // cores other processes kept busy in that window
  double wall_s = 0;  // when the window ended (steady clock)
};

// The thread count for the next window. `proposed` (threads_for_free_cores)
// is tried when no trusted timing of it exists; otherwise the count that ran
// fastest among the trusted timings, where `proposed` wins unless another ran
// more than kThreadTimingTolerance faster. Trusted: measured within
// kThreadTimingMemorySeconds and with the others' load within
// kThreadTimingSameLoadCores of `others_now`.
int faster_thread_count(int proposed, const std::map<int, ThreadTiming>& timings, double others_now, double wall_now);

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
