#pragma once

namespace fskin {

// Makes the BLAS library that LibTorch calls run each matrix product on the
// calling thread, when that library is OpenBLAS (found at run time, so builds
// against MKL or a GPU LibTorch are unaffected). Returns whether it did.
//
// Why: LibTorch already splits work across its own OpenMP threads. OpenBLAS's
// pthread build keeps a second pool; on a few cores the two pools spin and
// yield against each other. Measured on the 2-core CI machine: one Fast-SNARF
// training step 0.65 s with both pools, 0.28 s with single-threaded BLAS
// (docs/benchmarks.md, "CPU threads").
bool use_single_threaded_blas();

// use_single_threaded_blas() for one scope, the previous thread count back at
// its end: the Python module's training and evaluation run as the CLI's do,
// inside a process whose other products keep the user's setting.
class SingleThreadedBlasScope {
 public:
  SingleThreadedBlasScope();
  ~SingleThreadedBlasScope();
  SingleThreadedBlasScope(const SingleThreadedBlasScope&) = delete;
  SingleThreadedBlasScope& operator=(const SingleThreadedBlasScope&) = delete;

 private:
  int previous_ = -1;  // -1: not OpenBLAS, nothing to restore
};

}  // namespace fskin
