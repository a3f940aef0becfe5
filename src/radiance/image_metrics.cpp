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

double ssim(const torch::Tensor& image, const torch::Tensor& reference) {
  check_pair(image, reference, "ssim");
  FSKIN_CHECK(image.size(0) >= 11 && image.size(1) >= 11, "ssim: images must be at least 11 x 11, got {} x {}",
              image.size(1), image.size(0));
  const auto coordinates = torch::arange(11, torch::kFloat64) - 5;
  auto g = torch::exp(-coordinates.pow(2) / (2 * 1.5 * 1.5));
  g = g / g.sum();
  const auto window = torch::outer(g, g).expand({3, 1, 11, 11}).contiguous();
  const auto x = image.to(torch::kFloat64).permute({2, 0, 1}).unsqueeze(0);
  const auto y = reference.to(torch::kFloat64).permute({2, 0, 1}).unsqueeze(0);
  const auto filter = [&](const torch::Tensor& t) { return torch::conv2d(t, window, torch::Tensor(), at::IntArrayRef{1}, at::IntArrayRef{0}, at::IntArrayRef{1}, 3); };
  const auto mx = filter(x), my = filter(y);
  const auto sxx = filter(x * x) - mx * mx, syy = filter(y * y) - my * my, sxy = filter(x * y) - mx * my;
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  const auto map = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2));
  return map.mean().item<double>();
}

}  // namespace fskin
