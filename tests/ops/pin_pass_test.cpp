// The fused PIN pass's vectorisable math, called directly.
#include "ops/pin_pass/vector_math.h"

#include <gtest/gtest.h>

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
  EXPECT_NEAR(softplus100(0.0f), std::log(2.0) / 100, 1e-9);
  EXPECT_GE(softplus100(-5.0f), 0.0f);
  EXPECT_LT(softplus100(-5.0f), 1e-19f);  // exp(-500) clamps near zero, no NaN or negative
  EXPECT_FLOAT_EQ(softplus100(5.0f), 5.0f);
}

TEST(PinPassMath, ExpAndLog1pPiecesAreAccurate) {
  for (float t : {-39.9f, -10.3f, -1.0f, -0.3466f, -1e-4f, 0.0f}) {
    EXPECT_NEAR(exp_nonpositive(t) / std::exp(static_cast<double>(t)), 1.0, 1e-6) << t;
  }
  EXPECT_NEAR(exp_nonpositive(-100.0f), std::exp(-40.0), 1e-22);  // clamped: no subnormals
  for (float u : {0.0f, 1e-7f, 0.01f, 0.5f, 1.0f}) {
    EXPECT_NEAR(log1p_unit(u), std::log1p(static_cast<double>(u)), 1e-7) << u;
  }
}

}  // namespace
}  // namespace fskin::vector_math
