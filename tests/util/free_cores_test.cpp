#include "fskin/util/free_cores.h"

#include <ATen/Parallel.h>
#include <gtest/gtest.h>

#include <chrono>
#include <ctime>

namespace fskin {
namespace {

TEST(FreeCores, ThreadsFollowTheFreeCoresWithABandAgainstFlapping) {
  struct Case {
    double free_cores;
    int current, max_threads, expected;
    const char* why;
  };
  const Case cases[] = {
      {2.0, 2, 2, 2, "two cores, nothing else running: keep both threads"},
      {1.55, 2, 2, 2, "a neighbour using half a core or less: keep both"},
      {1.0, 2, 2, 1, "a second training or a compiler taking a core: one thread"},
      {1.45, 2, 2, 1, "just under the lower edge of the band: one thread"},
      {1.7, 1, 2, 1, "inside the band from one thread: stay"},
      {1.8, 1, 2, 2, "well above the band: back to two"},
      {0.0, 2, 2, 1, "never below one"},
      {-3.0, 8, 8, 1, "never below one, whatever the estimate"},
      {64.0, 1, 8, 8, "never above the maximum"},
      {5.0, 12, 8, 5, "more threads than free cores: down to the free count"},
      {5.6, 8, 8, 6, "many cores: down to the nearest count"},
      {6.9, 4, 8, 7, "many cores: up to the count below free + 0.25"},
      {4.5, 4, 8, 4, "many cores: inside the band, stay"},
      {0.2, 1, 1, 1, "one core: nothing to choose"},
  };
  for (const auto& c : cases)
    EXPECT_EQ(threads_for_free_cores(c.free_cores, c.current, c.max_threads), c.expected)
        << c.why << " (free " << c.free_cores << ", current " << c.current << ", max " << c.max_threads << ")";
}

TEST(FreeCores, AProposalMeasuredSlowerUnderTheSameLoadIsNotTaken) {
  const double now = 100;
  // Nothing measured at the proposal: try it.
  EXPECT_EQ(faster_thread_count(1, {{2, {0.5, 1.0, now}}}, 1.0, now), 1);
  // One thread measured faster than two (a training step next to a neighbour): one.
  EXPECT_EQ(faster_thread_count(1, {{1, {0.3, 1.3, now}}, {2, {0.5, 1.0, now - 1}}}, 1.3, now), 1);
  // Two threads measured faster (large parallel regions next to busy loops): stay at two.
  EXPECT_EQ(faster_thread_count(1, {{1, {1.2, 1.3, now - 1}}, {2, {0.9, 1.0, now}}}, 1.0, now), 2);
  // Within the tolerance the proposal wins: fewer threads are kinder to the neighbour.
  EXPECT_EQ(faster_thread_count(1, {{1, {1.0, 1.3, now - 1}}, {2, {0.96, 1.0, now}}}, 1.0, now), 1);
  // A timing older than the memory is not trusted: the proposal is tried again.
  EXPECT_EQ(faster_thread_count(1, {{1, {1.2, 1.3, now - kThreadTimingMemorySeconds - 1}}, {2, {0.9, 1.0, now}}},
                                1.0, now),
            1);
  // Nor one measured under another load (the neighbour has left since).
  EXPECT_EQ(faster_thread_count(2, {{1, {0.3, 1.3, now}}, {2, {0.5, 1.0, now - 5}}}, 0.0, now), 2);
  // The fastest of several trusted counts.
  EXPECT_EQ(faster_thread_count(4, {{2, {0.9, 2, now}}, {3, {0.6, 2, now}}, {4, {0.8, 2, now}}, {6, {0.7, 2, now}}},
                                2, now),
            3);
}

TEST(FreeCores, OthersAreTheMachinesBusyTimeLessOurOwn) {
  CpuTimes before{100.0, 500.0, 20.0, 4};
  CpuTimes after{102.0, 505.0, 22.0, 4};  // 5 core-seconds busy in 2 s, 2 of them ours
  EXPECT_DOUBLE_EQ(cores_used_by_others(before, after), 1.5);
  after.self_s = 26.0;  // clock granularity can make ours exceed the machine's
  EXPECT_DOUBLE_EQ(cores_used_by_others(before, after), 0.0);
  EXPECT_DOUBLE_EQ(cores_used_by_others(after, after), 0.0);
}

TEST(FreeCores, ReadsThisMachineAndCountsOurOwnWorkAsOurs) {
  const auto before = read_cpu_times();
  ASSERT_TRUE(before.has_value()) << "/proc/stat unreadable";
  EXPECT_GE(before->cores, 1);
  // Spin until this process has used 0.4 s of CPU (by the C library's
  // clock, not /proc), however long a loaded machine makes that take.
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  volatile double x = 1;
  while (static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC < 0.4 &&
         std::chrono::steady_clock::now() - start < std::chrono::seconds(30)) {
    x = x * 1.0000001 + 1e-9;
  }
  const auto after = read_cpu_times();
  ASSERT_TRUE(after.has_value());
  const double ours = after->self_s - before->self_s;
  EXPECT_GT(ours, 0.25);  // the spin above, on this thread (tick accounting: slack)
  // The machine's busy time includes ours (tick accounting: 0.1 s slack).
  EXPECT_GE(after->machine_busy_s - before->machine_busy_s, ours - 0.1);
  EXPECT_GT(after->wall_s - before->wall_s, 0.3);
}

TEST(FreeCores, EnablingSetsTheMaximumAndFollowingIsANoOpWhenOff) {
  const int before = at::get_num_threads();
  follow_free_cores_up_to(2);
  EXPECT_TRUE(following_free_cores());
  EXPECT_EQ(at::get_num_threads(), 2);
  stop_following_free_cores();
  EXPECT_FALSE(following_free_cores());
  at::set_num_threads(1);
  follow_free_cores();  // off: leaves the count alone
  EXPECT_EQ(at::get_num_threads(), 1);
  follow_free_cores_up_to(1);  // one thread: nothing to follow
  EXPECT_FALSE(following_free_cores());
  at::set_num_threads(before);
}

}  // namespace
}  // namespace fskin
