// The fused PIN pass's vectorisable math, called directly.
#include "ops/pin_pass/vector_math.h"

#include <gtest/gtest.h>

#pragma GCC diagnostic ignored "-Wpsabi"  // 64-byte vectors inside one function

#include <cmath>

namespace fskin::vector_math {
namespace {

TEST(PinPassMath, SineIsAccurateOverTheSirenRange) {
  // SIREN arguments w0 (W x + b) stay well inside +-100.
  double worst = 0;
  for (int i = -2000000; i <= 2000000; ++i) {
    const float x = static_cast<float>(i) * 5e-5f;
    worst = std::max(worst, std::abs(static_cast<double>(fskin::vector_math::sin(x)) - std::sin(static_cast<double>(x))));
  }
  EXPECT_LT(worst, 2e-7);
  EXPECT_FLOAT_EQ(fskin::vector_math::sin(0.0f), 0.0f);
}

TEST(PinPassMath, SoftplusMatchesItsDefinition) {
  for (int i = -1000000; i <= 1000000; ++i) {
    const float z = static_cast<float>(i) * 1e-4f;  // [-100, 100]: the maps' beta x
    const double exact = z > 0 ? z + std::log1p(std::exp(-static_cast<double>(z))) : std::log1p(std::exp(z));
    // The table's error plus rounding z + |z| (half an ulp of 2 |z|).
    ASSERT_NEAR(softplus(z), exact, 2e-6 + 1.2e-7 * std::abs(z)) << z;
  }
  EXPECT_NEAR(softplus(0.0f), std::log(2.0), 2e-6);
  EXPECT_EQ(softplus(-500.0f), 0.0f);  // past the table's end: no NaN or negative
  EXPECT_EQ(softplus(500.0f), 500.0f);
}

TEST(PinPassMath, Log1pExpTableIsAccurateAndNeverNegative) {
  double worst = 0;
  for (int i = 0; i <= 2000000; ++i) {
    const float a = static_cast<float>(i) * 1e-5f;  // [0, 20]: the table, its end at 16, the tail
    const float g = log1p_exp_negative(a);
    ASSERT_GE(g, 0.0f) << a;
    worst = std::max(worst, std::abs(g - std::log1p(std::exp(-static_cast<double>(a)))));
  }
  EXPECT_LT(worst, 2e-6);
  EXPECT_EQ(log1p_exp_negative(16.0f), 0.0f);
  EXPECT_EQ(log1p_exp_negative(1e30f), 0.0f);
}

// The CPU kernel's 16-lane versions compute what the scalar (CUDA) ones do.
TEST(PinPassMath, SixteenLanesMatchOneLane) {
  using Lanes = float __attribute__((vector_size(16 * sizeof(float))));
  for (int block = 0; block < 200; ++block) {
    Lanes x;
    for (int l = 0; l < 16; ++l) x[l] = static_cast<float>(block * 16 + l - 1600) * 0.013f;  // [-20.8, 20.8]
    const Lanes s = fskin::vector_math::sin(x), g = log1p_exp_negative(magnitude(x)), p = softplus(x);
    for (int l = 0; l < 16; ++l) {
      EXPECT_NEAR(s[l], fskin::vector_math::sin(x[l]), 1e-7) << x[l];
      EXPECT_NEAR(g[l], log1p_exp_negative(std::abs(x[l])), 1e-7) << x[l];
      EXPECT_NEAR(p[l], softplus(x[l]), 1e-6) << x[l];
    }
  }
}

}  // namespace
}  // namespace fskin::vector_math
