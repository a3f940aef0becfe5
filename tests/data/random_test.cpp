#include "fskin/data/random.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fskin {
namespace {

TEST(Random, EngineIsTheStandardMersenneTwister) {
  // The C++ standard fixes the 10000th output of a default-seeded mt19937_64.
  Rng rng(5489u);
  uint64_t value = 0;
  for (int i = 0; i < 10000; ++i) value = rng.next_u64();
  EXPECT_EQ(value, 9981545732273789042ULL);
}

TEST(Random, UniformIsTheTop53BitsOfTheEngine) {
  Rng a(7), b(7);
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(a.uniform(), static_cast<double>(b.next_u64() >> 11) * 0x1.0p-53);
}

TEST(Random, MomentsOfUniformAndNormal) {
  Rng rng(3);
  const int n = 200000;
  double su = 0, sn = 0, sn2 = 0;
  for (int i = 0; i < n; ++i) {
    const double u = rng.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    su += u;
    const double z = rng.normal();
    sn += z;
    sn2 += z * z;
  }
  EXPECT_NEAR(su / n, 0.5, 0.005);
  EXPECT_NEAR(sn / n, 0.0, 0.01);
  EXPECT_NEAR(sn2 / n, 1.0, 0.02);
}

TEST(Random, IndexCoversTheRangeAndItemStreamsDiffer) {
  Rng rng(11);
  std::vector<int> hits(7, 0);
  for (int i = 0; i < 7000; ++i) ++hits[rng.index(7)];
  for (int h : hits) EXPECT_GT(h, 800);
  EXPECT_EQ(Rng::for_item(1, 2).next_u64(), Rng::for_item(1, 2).next_u64());
  EXPECT_NE(Rng::for_item(1, 2).next_u64(), Rng::for_item(1, 3).next_u64());
  EXPECT_NE(Rng::for_item(1, 2).next_u64(), Rng::for_item(2, 2).next_u64());
}

}  // namespace
}  // namespace fskin
