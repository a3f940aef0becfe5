#include "fskin/networks/siren.h"

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

void SirenOptions::validate() const {
  FSKIN_CHECK(input_dim > 0, "SirenOptions: input_dim must be positive, got {}", input_dim);
  FSKIN_CHECK(hidden_dim > 0, "SirenOptions: hidden_dim must be positive, got {}", hidden_dim);
  FSKIN_CHECK(output_dim > 0, "SirenOptions: output_dim must be positive, got {}", output_dim);
  FSKIN_CHECK(num_layers >= 1, "SirenOptions: num_layers must be >= 1, got {}", num_layers);
  FSKIN_CHECK(std::isfinite(first_omega) && first_omega > 0,
              "SirenOptions: first_omega must be positive, got {}", first_omega);
  FSKIN_CHECK(std::isfinite(hidden_omega) && hidden_omega > 0,
              "SirenOptions: hidden_omega must be positive, got {}", hidden_omega);
  FSKIN_CHECK(!linear_output || num_layers >= 2,
              "SirenOptions: linear_output needs num_layers >= 2 (one sine layer before it), got {}", num_layers);
}

SirenImpl::SirenImpl(const SirenOptions& o) : options_(o) {
  o.validate();
  torch::NoGradGuard no_grad;
  for (int64_t l = 0; l < o.num_layers; ++l) {
    const int64_t in = l == 0 ? o.input_dim : o.hidden_dim;
    const int64_t out = l + 1 == o.num_layers ? o.output_dim : o.hidden_dim;
    auto layer = register_module("linear" + std::to_string(l), torch::nn::Linear(in, out));
    // First layer: frequencies up to w0 per unit input. Later layers: with
    // arcsine-distributed inputs h, w0 W h is ~ N(0, 1), so every sine layer's
    // output is arcsine-distributed again (SIREN paper, section 3.2). A linear
    // output layer gets the same unit-variance W h without the 1/w0.
    const bool linear = o.linear_output && l + 1 == o.num_layers;
    const double bound = l == 0 ? 1.0 / static_cast<double>(in)
                                : std::sqrt(6.0 / static_cast<double>(in)) / (linear ? 1.0 : o.hidden_omega);
    layer->weight.uniform_(-bound, bound);
    layers_.push_back(layer);
  }
}

torch::Tensor SirenImpl::hidden(const torch::Tensor& x) {
  FSKIN_CHECK(x.dim() >= 1 && x.size(-1) == options_.input_dim, "Siren: input must be [..., {}], got {}",
              options_.input_dim, shape_string(x.sizes()));
  torch::Tensor h = x;
  for (size_t l = 0; l + 1 < layers_.size(); ++l) {
    h = torch::sin((l == 0 ? options_.first_omega : options_.hidden_omega) * layers_[l]->forward(h));
  }
  return h;
}

torch::Tensor SirenImpl::forward(const torch::Tensor& x) {
  const auto out = layers_.back()->forward(hidden(x));
  if (options_.linear_output) return out;
  return torch::sin((layers_.size() == 1 ? options_.first_omega : options_.hidden_omega) * out);
}

}  // namespace fskin
