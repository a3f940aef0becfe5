#pragma once
// The binary entropy -(p ln p + (1 - p) ln(1 - p)), elementwise: zero at 0 and
// 1, ln 2 at one half. The Gaussian avatar's opacity prior takes it of each
// Gaussian's opacity (opacity_prior.h), the unseen-view prior of each pixel's
// (unseen_view_prior.h).
#include <torch/torch.h>

namespace fskin {

// p clamped to [eps, 1 - eps] first, so that the gradient stays finite.
inline torch::Tensor binary_entropy(const torch::Tensor& p, double eps) {
  const auto q = p.clamp(eps, 1 - eps);
  return -(q * q.log() + (1 - q) * (1 - q).log());
}

}  // namespace fskin
