#include "fskin/core/plausibility.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <limits>

#include "test_util.h"

namespace fskin {
namespace {

TEST(Plausibility, AcceptsCharactersFromCentimetresToKilometres) {
  expect_plausible(torch::tensor({0.01, -30.0, 5e3}), "vertices");
  expect_plausible(torch::zeros({0, 3}), "empty");
}

TEST(Plausibility, RejectsHugeNonFiniteAndIntegerValuesNamingTheInput) {
  testing::expect_error([] { expect_plausible(torch::tensor({1.0, -2e6}), "a.npz: joints"); },
                        {"a.npz: joints", "implausible magnitude", "2e+06"});
  testing::expect_error(
      [] { expect_plausible(torch::tensor({std::numeric_limits<double>::quiet_NaN()}), "b.npz: vertices"); },
      {"b.npz: vertices", "non-finite"});
  testing::expect_error([] { expect_plausible(torch::ones(2, torch::kInt64), "c.npz: bones"); },
                        {"c.npz: bones", "floating-point"});
}

}  // namespace
}  // namespace fskin
