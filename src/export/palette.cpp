#include "fskin/export/palette.h"

#include <torch/torch.h>

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {
namespace {

// HSV (all in [0, 1]) to RGB in [0, 1].
std::array<double, 3> hsv_to_rgb(double h, double s, double v) {
  const double sector = std::fmod(h, 1.0) * 6.0;
  const int i = static_cast<int>(std::floor(sector)) % 6;
  const double f = sector - std::floor(sector);
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  switch (i) {
    case 0: return {v, t, p};
    case 1: return {q, v, p};
    case 2: return {p, v, t};
    case 3: return {p, q, v};
    case 4: return {t, p, v};
    default: return {v, p, q};
  }
}

void check_weights(const torch::Tensor& weights, const char* function) {
  expect_shape(weights, {-1, -1}, std::string(function) + ": weights");
  expect_floating(weights, std::string(function) + ": weights");
  FSKIN_CHECK(weights.size(1) > 0, "{}: weights have no bone columns", function);
  expect_finite(weights, std::string(function) + ": weights");
}

}  // namespace

torch::Tensor bone_palette(int64_t num_bones) {
  FSKIN_CHECK(num_bones > 0, "bone_palette: number of bones must be positive, got {}",
              num_bones);
  constexpr double kGoldenAngle = 0.3819660112501051;  // 1 - 1/phi, in turns
  constexpr double kSaturation[3] = {0.75, 0.55, 0.9};
  constexpr double kValue[2] = {0.95, 0.75};
  auto palette = torch::empty({num_bones, 3}, torch::kUInt8);
  auto out = palette.accessor<uint8_t, 2>();
  for (int64_t j = 0; j < num_bones; ++j) {
    const auto rgb = hsv_to_rgb(0.02 + kGoldenAngle * j, kSaturation[j % 3], kValue[j % 2]);
    for (int c = 0; c < 3; ++c) out[j][c] = static_cast<uint8_t>(std::lround(255 * rgb[c]));
  }
  return palette;
}

torch::Tensor color_by_argmax_weight(const torch::Tensor& weights) {
  check_weights(weights, "color_by_argmax_weight");
  return bone_palette(weights.size(1)).index_select(0, weights.argmax(1));
}

torch::Tensor color_by_blended_weights(const torch::Tensor& weights) {
  check_weights(weights, "color_by_blended_weights");
  const auto palette = bone_palette(weights.size(1)).to(torch::kFloat64);
  return weights.to(torch::kFloat64).matmul(palette).round().clamp(0, 255).to(torch::kUInt8);
}

}  // namespace fskin
