// fskin_bench's entry point: Google Benchmark's main, after the same runtime
// setup as the CLI's long-running commands (fskin/util/runtime_restart.h,
// blas_threads.h), so the benchmarks measure what `fskin` runs.
#include <benchmark/benchmark.h>

#include "fskin/util/runtime_restart.h"
#include "fskin/util/blas_threads.h"
#include "fskin/util/stopwatch.h"

int main(int argc, char** argv) {
  fskin::restart_with_runtime_settings(argv, /*long_running=*/true);
  fskin::use_single_threaded_blas();
  fskin::set_cuda_timing(true);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
