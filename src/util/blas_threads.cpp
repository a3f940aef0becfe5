#include "fskin/util/blas_threads.h"

#include <dlfcn.h>

namespace fskin {

namespace {

using SetThreads = void (*)(int);
using GetThreads = int (*)();

}  // namespace

SingleThreadedBlasScope::SingleThreadedBlasScope() {
  auto* get_threads = reinterpret_cast<GetThreads>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  if (get_threads == nullptr) return;
  previous_ = get_threads();
  use_single_threaded_blas();
}

SingleThreadedBlasScope::~SingleThreadedBlasScope() {
  if (previous_ < 1) return;
  auto* set_threads = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (set_threads != nullptr) set_threads(previous_);
}

bool use_single_threaded_blas() {
  // Looked up instead of linked: LibTorch reaches BLAS through whatever
  // libblas.so.3 the system selects, and we must not pull in a second one.
  auto* set_threads = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (set_threads == nullptr) return false;
  set_threads(1);
  return true;
}

}  // namespace fskin
