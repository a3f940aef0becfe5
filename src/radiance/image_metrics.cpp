#include "fskin/radiance/image_metrics.h"

#include <torch/torch.h>

#include <cmath>
#include <limits>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {
namespace {

void check_pair(const torch::Tensor& image, const torch::Tensor& reference, const char* what) {
  expect_shape(image, {-1, -1, 3}, std::string(what) + ": image");
  expect_shape(reference, {image.size(0), image.size(1), 3}, std::string(what) + ": reference");
  expect_floating(image, std::string(what) + ": image");
  expect_floating(reference, std::string(what) + ": reference");
}

}  // namespace

double psnr(const torch::Tensor& image, const torch::Tensor& reference) {
  check_pair(image, reference, "psnr");
  const double mse = (image.to(torch::kFloat64) - reference.to(torch::kFloat64)).pow(2).mean().item<double>();
  FSKIN_CHECK(std::isfinite(mse), "psnr: the images hold non-finite values (a diverged model renders NaN)");
  return mse > 0 ? -10.0 * std::log10(mse) : std::numeric_limits<double>::infinity();
}

torch::Tensor ssim_tensor(const torch::Tensor& image, const torch::Tensor& reference) {
  check_pair(image, reference, "ssim");
  FSKIN_CHECK(image.size(0) >= 11 && image.size(1) >= 11, "ssim: images must be at least 11 x 11, got {} x {}",
              image.size(1), image.size(0));
  const auto options = image.options();
  const auto coordinates = torch::arange(11, options) - 5;
  auto g = torch::exp(-coordinates.pow(2) / (2 * 1.5 * 1.5));
  g = g / g.sum();
  // The 11 x 11 window is the outer product of g with itself: filtered as a
  // column then a row (22 instead of 121 multiplications per pixel).
  const auto column = g.view({1, 1, 11, 1}).expand({3, 1, 11, 1}).contiguous();
  const auto row = g.view({1, 1, 1, 11}).expand({3, 1, 1, 11}).contiguous();
  const auto x = image.permute({2, 0, 1}).unsqueeze(0);
  const auto y = reference.to(options).permute({2, 0, 1}).unsqueeze(0);
  const auto filter = [&](const torch::Tensor& t) {
    const auto conv = [](const torch::Tensor& input, const torch::Tensor& weight) {
      return torch::conv2d(input, weight, torch::Tensor(), at::IntArrayRef{1}, at::IntArrayRef{0}, at::IntArrayRef{1},
                           3);
    };
    return conv(conv(t, column), row);
  };
  const auto mx = filter(x), my = filter(y);
  const auto sxx = filter(x * x) - mx * mx, syy = filter(y * y) - my * my, sxy = filter(x * y) - mx * my;
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  const auto map = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2));
  return map.mean();
}

double ssim(const torch::Tensor& image, const torch::Tensor& reference) {
  return ssim_tensor(image.to(torch::kFloat64), reference.to(torch::kFloat64)).item<double>();
}

}  // namespace fskin
