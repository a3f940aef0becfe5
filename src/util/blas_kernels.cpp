#include "fskin/util/blas_kernels.h"

#include <dlfcn.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>

namespace fskin {

CpuVectorFeatures cpu_vector_features() {
  CpuVectorFeatures features;
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  features.avx2_fma = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  features.avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512cd") &&
                    __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
                    __builtin_cpu_supports("avx512vl");
#endif
  return features;
}

std::optional<std::string> better_openblas_core(const std::string& detected_core, const CpuVectorFeatures& features) {
  std::string lower = detected_core;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  if (lower != "prescott") return std::nullopt;
  if (features.avx512) return "SkylakeX";
  if (features.avx2_fma) return "Haswell";
  return std::nullopt;
}

std::optional<std::string> openblas_core() {
  // Looked up instead of linked, as in blas_threads.cpp: LibTorch reaches BLAS
  // through whatever libblas.so.3 the system selects.
  using GetCoreName = char* (*)();
  auto* get_core_name = reinterpret_cast<GetCoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  if (get_core_name == nullptr) return std::nullopt;
  const char* name = get_core_name();
  if (name == nullptr) return std::nullopt;
  return std::string(name);
}

std::optional<std::string> openblas_core_setting() {
  // Set (by the user, or by the restart): respected, and no loop.
  if (std::getenv("OPENBLAS_CORETYPE") != nullptr) return std::nullopt;
  const auto detected = openblas_core();
  if (!detected) return std::nullopt;
  return better_openblas_core(*detected, cpu_vector_features());
}

}  // namespace fskin
