#include "fskin/radiance/image_metrics.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "test_util.h"

namespace fskin {
namespace {

TEST(ImageMetrics, PsnrOfAKnownError) {
  const auto a = torch::full({16, 16, 3}, 0.5, torch::kFloat64);
  EXPECT_NEAR(psnr(a + 0.1, a), 20.0, 1e-9);  // mse 0.01
  EXPECT_NEAR(psnr(a + 0.01, a), 40.0, 1e-6);
  EXPECT_TRUE(std::isinf(psnr(a, a)));
}

TEST(ImageMetrics, SsimIsOneForEqualImagesAndFallsWithNoise) {
  torch::manual_seed(0);
  const auto image = torch::rand({32, 40, 3});
  EXPECT_NEAR(ssim(image, image), 1.0, 1e-9);
  const double slight = ssim((image + 0.02 * torch::randn({32, 40, 3})).clamp(0, 1), image);
  const double strong = ssim((image + 0.3 * torch::randn({32, 40, 3})).clamp(0, 1), image);
  EXPECT_LT(slight, 1.0);
  EXPECT_GT(slight, 0.9);
  EXPECT_LT(strong, slight - 0.2);
  // A constant shift keeps the structure: SSIM stays high (only its luminance
  // term falls) while PSNR drops to 20 dB.
  EXPECT_GT(ssim((image * 0.8 + 0.1), image * 0.8), 0.95);
  EXPECT_NEAR(psnr((image * 0.8 + 0.1), image * 0.8), 20.0, 1e-3);
}

TEST(ImageMetrics, RejectsMismatchedImages) {
  testing::expect_error([] { psnr(torch::zeros({4, 4, 3}), torch::zeros({4, 5, 3})); }, {"psnr", "reference"});
  testing::expect_error([] { ssim(torch::zeros({8, 8, 3}), torch::zeros({8, 8, 3})); }, {"ssim", "11"});
}

}  // namespace
}  // namespace fskin
