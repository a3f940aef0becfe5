#pragma once
// View-dependent colour from real spherical harmonics of degree 0-3, in the
// basis, signs and constants of 3D Gaussian splatting's renderer (so that
// coefficients exported as a 3DGS .ply mean the same in its viewers):
// colour = max(0, sum_k c_k Y_k(d) + 0.5).
#include <torch/types.h>

namespace fskin {

// Coefficients per degree: (degree + 1)^2.
constexpr int64_t spherical_harmonics_coefficients(int64_t degree) { return (degree + 1) * (degree + 1); }

// coefficients [N, K, C] with K = (d + 1)^2 for d in 0..3, directions [N, 3]
// (unit, from the eye to the Gaussian) -> colours [N, C]. Differentiable.
torch::Tensor spherical_harmonics_color(const torch::Tensor& coefficients, const torch::Tensor& directions);

// The degree-0 coefficient that gives `color` [..., C] (the inverse of the
// constant term): (color - 0.5) / Y_0.
torch::Tensor color_to_spherical_harmonics_dc(const torch::Tensor& color);
// Its inverse, the view-independent part of the colour: dc Y_0 + 0.5.
torch::Tensor spherical_harmonics_dc_color(const torch::Tensor& dc);

}  // namespace fskin
