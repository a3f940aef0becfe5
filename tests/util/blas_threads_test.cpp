#include "fskin/util/blas_threads.h"

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

namespace fskin {
namespace {

// Every test process runs with single-threaded BLAS, as the CLI does: the
// training tests are ~2x faster on two cores (see blas_threads.h).
const bool kConfigured = [] {
  use_single_threaded_blas();
  return true;
}();

TEST(BlasThreads, OpenBlasRunsOnTheCallingThreadAndStillMultipliesCorrectly) {
  ASSERT_TRUE(kConfigured);
  using GetThreads = int (*)();
  auto* get_threads = reinterpret_cast<GetThreads>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  EXPECT_EQ(use_single_threaded_blas(), get_threads != nullptr);
  if (get_threads != nullptr) EXPECT_EQ(get_threads(), 1);

  torch::manual_seed(0);
  const auto a = torch::randn({300, 200}), b = torch::randn({200, 100});
  const auto reference = torch::mm(a.to(torch::kFloat64), b.to(torch::kFloat64));
  EXPECT_LT((torch::mm(a, b).to(torch::kFloat64) - reference).abs().max().item<double>(), 1e-3);
}

TEST(BlasThreads, AScopeRestoresThePreviousThreadCount) {
  using GetThreads = int (*)();
  using SetThreads = void (*)(int);
  auto* get_threads = reinterpret_cast<GetThreads>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  auto* set_threads = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (get_threads == nullptr || set_threads == nullptr) GTEST_SKIP() << "BLAS is not OpenBLAS";
  set_threads(2);
  const int before = get_threads();  // 2, or 1 where OpenBLAS has one thread at most
  {
    const SingleThreadedBlasScope scope;
    EXPECT_EQ(get_threads(), 1);
  }
  EXPECT_EQ(get_threads(), before);
  use_single_threaded_blas();  // the suite's setting again
}

}  // namespace
}  // namespace fskin
