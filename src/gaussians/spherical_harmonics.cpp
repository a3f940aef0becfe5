#include "fskin/gaussians/spherical_harmonics.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {
namespace {

// Y_0 and the constants of degrees 1-3 (3DGS's sh_utils / forward.cu).
constexpr double kY0 = 0.28209479177387814;
constexpr double kY1 = 0.4886025119029199;
constexpr double kY2[] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
                          0.5462742152960396};
constexpr double kY3[] = {-0.5900435899266435, 2.890611442640554,  -0.4570457994644658, 0.3731763325901154,
                          -0.4570457994644658, 1.445305721320277, -0.5900435899266435};

}  // namespace

torch::Tensor spherical_harmonics_color(const torch::Tensor& coefficients, const torch::Tensor& directions) {
  expect_shape(coefficients, {-1, -1, -1}, "spherical_harmonics_color: coefficients");
  expect_shape(directions, {coefficients.size(0), 3}, "spherical_harmonics_color: directions");
  const int64_t k = coefficients.size(1);
  FSKIN_CHECK(k == 1 || k == 4 || k == 9 || k == 16,
              "spherical_harmonics_color: {} coefficients per Gaussian; degrees 0-3 have 1, 4, 9 or 16", k);
  const auto c = [&](int64_t i) { return coefficients.select(1, i); };  // [N, C]
  auto result = kY0 * c(0);
  if (k > 1) {
    const auto x = directions.select(1, 0).unsqueeze(1), y = directions.select(1, 1).unsqueeze(1),
               z = directions.select(1, 2).unsqueeze(1);
    result = result - kY1 * y * c(1) + kY1 * z * c(2) - kY1 * x * c(3);
    if (k > 4) {
      const auto xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
      result = result + kY2[0] * xy * c(4) + kY2[1] * yz * c(5) + kY2[2] * (2 * zz - xx - yy) * c(6) +
               kY2[3] * xz * c(7) + kY2[4] * (xx - yy) * c(8);
      if (k > 9) {
        result = result + kY3[0] * y * (3 * xx - yy) * c(9) + kY3[1] * xy * z * c(10) +
                 kY3[2] * y * (4 * zz - xx - yy) * c(11) + kY3[3] * z * (2 * zz - 3 * xx - 3 * yy) * c(12) +
                 kY3[4] * x * (4 * zz - xx - yy) * c(13) + kY3[5] * z * (xx - yy) * c(14) +
                 kY3[6] * x * (xx - 3 * yy) * c(15);
      }
    }
  }
  return torch::clamp_min(result + 0.5, 0.0);
}

torch::Tensor color_to_spherical_harmonics_dc(const torch::Tensor& color) { return (color - 0.5) / kY0; }

torch::Tensor spherical_harmonics_dc_color(const torch::Tensor& dc) { return dc * kY0 + 0.5; }

}  // namespace fskin
