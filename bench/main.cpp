// fskin_bench's entry point: Google Benchmark's main, after the same BLAS
// setup as the CLI (fskin/util/blas_kernels.h, blas_threads.h), so the
// MLP-heavy benchmarks measure what `fskin` runs.
#include <benchmark/benchmark.h>

#include "fskin/util/blas_kernels.h"
#include "fskin/util/blas_threads.h"

int main(int argc, char** argv) {
  fskin::use_native_blas_kernels(argv);
  fskin::use_single_threaded_blas();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
