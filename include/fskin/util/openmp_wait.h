#pragma once
// How long the OpenMP threads of LibTorch's at::parallel_for (and fskin's
// kernels on it) spin before they sleep when waiting at a barrier.
#include <optional>
#include <string>

namespace fskin {

// Spin count fskin runs libgomp with unless the user chose a wait policy
// (docs/benchmarks.md, "Training next to other processes").
constexpr const char* kOpenMpSpinCount = "15000";

// The GOMP_SPINCOUNT to set given the user's GOMP_SPINCOUNT and
// OMP_WAIT_POLICY (nullptr when unset): kOpenMpSpinCount when both are
// unset, nullopt (respect the user's choice) otherwise.
std::optional<std::string> openmp_spin_setting(const char* gomp_spincount, const char* omp_wait_policy);

}  // namespace fskin
