#include "fskin/networks/input_normalization.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/core/error.h"

namespace fskin {
namespace {

TEST(InputNormalization, MapsTheBoxOntoTheUnitCubeAlongItsLongestSide) {
  // A "body" standing on y = 0, 1.7 m tall, 0.6 m wide, 0.3 m deep.
  const auto points = torch::tensor({{-0.3f, 0.0f, -0.1f}, {0.3f, 1.7f, 0.2f}});
  const auto n = InputNormalization::around(points);
  EXPECT_NEAR(n.centre[1], 0.85, 1e-6);
  EXPECT_NEAR(n.scale, 2.0 / 1.7, 1e-6);
  const auto u = n.apply(points);
  EXPECT_NEAR(u[0][1].item<float>(), -1.0f, 1e-5);
  EXPECT_NEAR(u[1][1].item<float>(), 1.0f, 1e-5);
  EXPECT_NEAR(u[1][0].item<float>(), 0.3f * 2.0f / 1.7f, 1e-5);
  EXPECT_TRUE(torch::allclose(n.unapply(u), points, 1e-6, 1e-6));
}

TEST(InputNormalization, IdentityByDefaultAndErrorsNameTheProblem) {
  const auto x = torch::randn({4, 5, 3});
  EXPECT_TRUE(torch::equal(InputNormalization{}.apply(x), x));
  EXPECT_THROW(InputNormalization::around(torch::zeros({2, 3})), Error);  // no volume
  EXPECT_THROW(InputNormalization{}.apply(torch::zeros({4, 2})), Error);
}

}  // namespace
}  // namespace fskin
