#include "fskin/data/random.h"

#include <cmath>

#include "fskin/core/error.h"

namespace fskin {

Rng Rng::for_item(uint64_t seed, uint64_t index) {
  // SplitMix64 finaliser: decorrelates neighbouring (seed, index) pairs.
  uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (index + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return Rng(z ^ (z >> 31));
}

double Rng::uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

int64_t Rng::index(int64_t count) {
  FSKIN_CHECK(count > 0, "Rng::index: count must be positive, got {}", count);
  // Rejection sampling avoids modulo bias and stays exact.
  const uint64_t n = static_cast<uint64_t>(count);
  const uint64_t limit = UINT64_MAX - UINT64_MAX % n;
  uint64_t value;
  do value = engine_();
  while (value >= limit);
  return static_cast<int64_t>(value % n);
}

double Rng::normal() {
  const double u1 = 1.0 - uniform();  // (0, 1]: log stays finite
  const double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace fskin
