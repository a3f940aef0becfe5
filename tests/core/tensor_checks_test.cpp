#include "fskin/core/tensor_checks.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <limits>

#include "test_util.h"

namespace fskin {
namespace {

TEST(TensorChecks, ShapeMismatchNamesTensorAndShapes) {
  expect_shape(torch::zeros({2, 5, 3}), {-1, -1, 3}, "x");
  testing::expect_error([] { expect_shape(torch::zeros({2, 5, 4}), {-1, -1, 3}, "x_posed"); },
                        {"x_posed", "[*, *, 3]", "[2, 5, 4]"});
  testing::expect_error([] { expect_shape(torch::Tensor(), {3}, "bones"); }, {"bones", "undefined"});
}

TEST(TensorChecks, ShapeStringMarksWildcards) {
  EXPECT_EQ(shape_string(std::vector<int64_t>{8, -1, 3}), "[8, *, 3]");
  EXPECT_EQ(shape_string(std::vector<int64_t>{}), "[]");
}

TEST(TensorChecks, ExpectFloatingRejectsIntegers) {
  expect_floating(torch::ones(1, torch::kFloat64), "a");
  testing::expect_error([] { expect_floating(torch::ones(1, torch::kInt64), "faces"); },
                        {"faces", "floating-point", "Long"});
}

TEST(TensorChecks, NonFiniteValuesAreReported) {
  auto t = torch::zeros({4});
  expect_finite(t, "t");
  t[2] = std::numeric_limits<float>::infinity();
  testing::expect_error([&] { expect_finite(t, "bones"); }, {"bones", "non-finite", "index 2"});
  expect_finite(torch::zeros({3}, torch::kInt64), "ints are always finite");
}

TEST(TensorChecks, FinitenessIsExactInEveryFloatingTypeAndAtEveryPosition) {
  // Doubles beyond float's range are finite; NaN is found wherever it sits
  // (the one-pass check works in blocks of eight, then a tail).
  expect_finite(torch::full({100}, 1e300, torch::kFloat64), "large doubles");
  for (const auto dtype : {torch::kFloat32, torch::kFloat64, torch::kFloat16, torch::kBFloat16}) {
    for (const int64_t at : {0, 7, 8, 99, 70000}) {
      auto t = torch::rand({70001}).to(dtype);
      t[at] = std::numeric_limits<float>::quiet_NaN();
      testing::expect_error([&] { expect_finite(t, "x"); }, {"x", "1 non-finite", fmt::format("index {}", at)});
    }
  }
}

}  // namespace
}  // namespace fskin
