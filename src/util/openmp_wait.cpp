#include "fskin/util/openmp_wait.h"

namespace fskin {

std::optional<std::string> openmp_spin_setting(const char* gomp_spincount, const char* omp_wait_policy) {
  if (gomp_spincount != nullptr || omp_wait_policy != nullptr) return std::nullopt;
  return std::string(kOpenMpSpinCount);
}

}  // namespace fskin
