#pragma once
// One exception type for everything fskin rejects: bad input files, wrong
// tensor shapes, non-finite transforms. Messages name the offending file,
// argument or tensor and say what was expected, so a user can act on them.
#include <stdexcept>
#include <string>

namespace fskin {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace fskin

// The CUDA kernels (nvcc, ops/common/cuda_launch.cuh) throw Error but format no messages.
#if !defined(__CUDACC__)
#include <fmt/format.h>

namespace fskin {

template <typename... Args>
[[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) {
  throw Error(fmt::format(format, std::forward<Args>(args)...));
}

}  // namespace fskin

// FSKIN_CHECK(cond, "format {}", args...) throws fskin::Error when cond is false.
#define FSKIN_CHECK(cond, ...)      \
  do {                              \
    if (!(cond)) {                  \
      ::fskin::fail(__VA_ARGS__);   \
    }                               \
  } while (false)

#endif  // !__CUDACC__
