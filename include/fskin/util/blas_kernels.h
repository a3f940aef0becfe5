#pragma once
// Which OpenBLAS kernels the process multiplies matrices with.
//
// Why: OpenBLAS picks its kernels (SSE3, AVX2, AVX-512 ...) from the CPU model
// once, when the library is loaded. The OpenBLAS of Debian 12 (0.3.21) does
// not know recent Xeons (e.g. Sapphire Rapids, the CI machines) and falls back
// to its Prescott kernels (SSE3): a full-size Fast-SNARF training step (8 x 256
// occupancy network) took 8.9 s with them and 2.5 s with the SkylakeX
// (AVX-512) kernels on the same 2-core VM (docs/benchmarks.md, "OpenBLAS
// kernels"). The only way to choose is the OPENBLAS_CORETYPE environment
// variable, which OpenBLAS reads at load time, so the choice has to be made
// before the process starts: see runtime_restart.h.
#include <optional>
#include <string>

namespace fskin {

struct CpuVectorFeatures {
  bool avx2_fma = false;  // what OpenBLAS's Haswell kernels need
  bool avx512 = false;    // AVX-512 F, CD, BW, DQ and VL: its SkylakeX kernels
};

// The running CPU's features (from CPUID).
CpuVectorFeatures cpu_vector_features();

// The OPENBLAS_CORETYPE to ask for when OpenBLAS chose `detected_core` on a
// CPU with `features`; nullopt when its choice is already right (it only
// falls back to "Prescott" on CPUs it does not recognise).
std::optional<std::string> better_openblas_core(const std::string& detected_core, const CpuVectorFeatures& features);

// The kernel set OpenBLAS is using ("SkylakeX", "Prescott" ...), or nullopt
// when LibTorch does not multiply through OpenBLAS (MKL, a GPU build).
std::optional<std::string> openblas_core();

// The OPENBLAS_CORETYPE this process should restart with: the better kernels
// when OpenBLAS fell back to slower ones than this CPU runs and the user has
// not set the variable; nullopt otherwise.
std::optional<std::string> openblas_core_setting();

}  // namespace fskin
