#include "fskin/util/blas_kernels.h"

#include <gtest/gtest.h>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

namespace fskin {
namespace {

TEST(BlasKernels, OnlyThePrescottFallbackIsReplacedAndOnlyByKernelsTheCpuRuns) {
  const CpuVectorFeatures none, avx2{true, false}, avx512{true, true};
  EXPECT_EQ(better_openblas_core("Prescott", avx512), "SkylakeX");
  EXPECT_EQ(better_openblas_core("PRESCOTT", avx2), "Haswell");
  EXPECT_FALSE(better_openblas_core("Prescott", none).has_value());
  // OpenBLAS recognised the CPU: its choice stands, even if it is not the widest.
  EXPECT_FALSE(better_openblas_core("Haswell", avx512).has_value());
  EXPECT_FALSE(better_openblas_core("Zen", avx2).has_value());
}

// The last "Core: NAME" line OpenBLAS printed (OPENBLAS_VERBOSE=2 prints one
// per load) and how many there were.
struct CoreLines {
  std::string last;
  int count = 0;
};

CoreLines run_cli_and_read_core_lines() {
  const std::string command =
      std::string("env -u OPENBLAS_CORETYPE OPENBLAS_VERBOSE=2 ") + FSKIN_CLI_PATH + " --version 2>&1";
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  CoreLines lines;
  if (!pipe) return lines;
  char buffer[512];
  while (std::fgets(buffer, sizeof buffer, pipe.get()) != nullptr) {
    std::string line(buffer);
    const auto at = line.find("Core: ");
    if (at == std::string::npos) continue;
    line = line.substr(at + 6);
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    lines.last = line;
    ++lines.count;
  }
  return lines;
}

TEST(BlasKernels, TheCliEndsOnTheBestKernelsThisCpuRuns) {
  const auto detected = openblas_core();
  if (!detected) GTEST_SKIP() << "LibTorch does not multiply through OpenBLAS here (MKL or a GPU build)";
  if (std::getenv("OPENBLAS_CORETYPE") != nullptr) {
    GTEST_SKIP() << "OPENBLAS_CORETYPE is set for this test process, so what OpenBLAS detects is not observable";
  }
  const auto better = better_openblas_core(*detected, cpu_vector_features());
  const CoreLines lines = run_cli_and_read_core_lines();
  // Only OpenBLAS builds that choose kernels at load time (DYNAMIC_ARCH, as
  // Debian's) report the choice, and only they can fall back.
  if (lines.count == 0) GTEST_SKIP() << "this OpenBLAS does not report its kernel choice (no DYNAMIC_ARCH)";
  if (better) {
    // Loaded once with the fallback, then restarted with the better kernels.
    EXPECT_EQ(lines.count, 2);
    EXPECT_EQ(lines.last, *better);
  } else {
    EXPECT_EQ(lines.count, 1) << "restarted although OpenBLAS's choice was right";
    EXPECT_EQ(lines.last, *detected);
  }
}

}  // namespace
}  // namespace fskin
