#include "fskin/networks/frequency_encoding.h"

#include <torch/torch.h>

#include <cmath>
#include <vector>

namespace fskin {

torch::Tensor positional_encoding(const torch::Tensor& x, int64_t frequencies) {
  if (frequencies == 0) return x;
  std::vector<torch::Tensor> parts{x};
  for (int64_t k = 0; k < frequencies; ++k) {
    const auto scaled = x * (std::ldexp(1.0, static_cast<int>(k)) * M_PI);
    parts.push_back(scaled.sin());
    parts.push_back(scaled.cos());
  }
  return torch::cat(parts, -1);
}

}  // namespace fskin
