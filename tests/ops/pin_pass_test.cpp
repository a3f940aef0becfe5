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
  double worst = 0;
  for (int i = -100000; i <= 100000; ++i) {
    const double x = i * 1e-5;  // z = 100 x in [-100, 100]
    const double z = 100 * x;
    const double exact = (z > 0 ? z + std::log1p(std::exp(-z)) : std::log1p(std::exp(z))) / 100;
    worst = std::max(worst, std::abs(softplus100(static_cast<float>(x)) - exact));
  }
  EXPECT_LT(worst, 1e-7);
  EXPECT_NEAR(softplus100(0.0f), std::log(2.0) / 100, 2e-8);  // the table's worst error / 100
  EXPECT_GE(softplus100(-5.0f), 0.0f);
  EXPECT_EQ(softplus100(-5.0f), 0.0f);  // z = -500: past the table's end, no NaN or negative
  EXPECT_FLOAT_EQ(softplus100(5.0f), 5.0f);
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
    const Lanes s = fskin::vector_math::sin(x), g = log1p_exp_negative(x < 0 ? -x : x), p = softplus100(x * 0.01f);
    for (int l = 0; l < 16; ++l) {
      EXPECT_NEAR(s[l], fskin::vector_math::sin(x[l]), 1e-7) << x[l];
      EXPECT_NEAR(g[l], log1p_exp_negative(std::abs(x[l])), 1e-7) << x[l];
      EXPECT_NEAR(p[l], softplus100(x[l] * 0.01f), 1e-9) << x[l];
    }
  }
}

}  // namespace
}  // namespace fskin::vector_math
