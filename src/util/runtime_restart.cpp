#include "fskin/util/runtime_restart.h"

#include <unistd.h>

#include <cstdlib>
#include <cstring>

#include "fskin/util/blas_kernels.h"
#include "fskin/util/openmp_wait.h"

namespace fskin {

EnvironmentSettings runtime_settings(bool long_running) {
  EnvironmentSettings settings;
  if (const auto core = openblas_core_setting()) settings.emplace_back("OPENBLAS_CORETYPE", *core);
  if (long_running) {
    if (const auto spin = openmp_spin_setting(std::getenv("GOMP_SPINCOUNT"), std::getenv("OMP_WAIT_POLICY"))) {
      settings.emplace_back("GOMP_SPINCOUNT", *spin);
    }
  }
  return settings;
}

bool is_long_running_command(int argc, char** argv) {
  static const char* const kLongRunning[] = {"train", "eval", "mesh", "animate", "data", "bench"};
  for (int i = 1; i < argc; ++i) {
    for (const char* name : kLongRunning) {
      if (std::strcmp(argv[i], name) == 0) return true;
    }
  }
  return false;
}

void restart_with_runtime_settings(char** argv, bool long_running) {
  const auto settings = runtime_settings(long_running);
  if (settings.empty()) return;
  for (const auto& [name, value] : settings) setenv(name.c_str(), value.c_str(), 1);
  execv("/proc/self/exe", argv);
  // exec failed (no /proc, say): carry on as we are.
  for (const auto& [name, value] : settings) unsetenv(name.c_str());
}

}  // namespace fskin
