#pragma once
// A seeded random source whose numbers are the same on every platform.
// std::uniform_real_distribution and std::normal_distribution are not
// specified bit-for-bit by the C++ standard (libstdc++, libc++ and MSVC give
// different sequences), so datasets built with them would differ between
// machines. std::mt19937_64 itself is fully specified; the mappings to
// uniform and normal numbers below are ours and use only exact arithmetic plus
// log/sqrt/cos (correctly rounded or within 1 ulp in every common libm).
#include <cstdint>

#include <random>

namespace fskin {

class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}
  // A stream for item `index` of a run seeded with `seed`: frames built in any
  // order (or resumed) draw the same numbers.
  static Rng for_item(uint64_t seed, uint64_t index);

  uint64_t next_u64() { return engine_(); }
  // Uniform in [0, 1) with 53 random bits.
  double uniform();
  double uniform(double low, double high) { return low + (high - low) * uniform(); }
  // Uniform integer in [0, count).
  int64_t index(int64_t count);
  // Standard normal (Box-Muller, one value per call).
  double normal();
  double normal(double mean, double stddev) { return mean + stddev * normal(); }

 private:
  std::mt19937_64 engine_;
};

}  // namespace fskin
