#include "fskin/networks/frequency_encoding.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace fskin {

double frequency_band_weight(int64_t band, double window) {
  const double open = std::clamp(window - static_cast<double>(band), 0.0, 1.0);
  return 0.5 * (1.0 - std::cos(M_PI * open));
}

torch::Tensor positional_encoding(const torch::Tensor& x, int64_t frequencies, double window) {
  if (frequencies == 0) return x;
  std::vector<torch::Tensor> parts{x};
  for (int64_t k = 0; k < frequencies; ++k) {
    const auto scaled = x * (std::ldexp(1.0, static_cast<int>(k)) * M_PI);
    const double weight = frequency_band_weight(k, window);
    if (weight == 1.0) {
      parts.push_back(scaled.sin());
      parts.push_back(scaled.cos());
    } else {
      parts.push_back(scaled.sin() * weight);
      parts.push_back(scaled.cos() * weight);
    }
  }
  return torch::cat(parts, -1);
}

}  // namespace fskin
