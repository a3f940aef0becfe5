#include "fskin/util/blas_threads.h"

#include <dlfcn.h>

namespace fskin {

bool use_single_threaded_blas() {
  // Looked up instead of linked: LibTorch reaches BLAS through whatever
  // libblas.so.3 the system selects, and we must not pull in a second one.
  using SetThreads = void (*)(int);
  auto* set_threads = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (set_threads == nullptr) return false;
  set_threads(1);
  return true;
}

}  // namespace fskin
