#include "fskin/networks/mlp.h"

#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

WeightNormLinearImpl::WeightNormLinearImpl(int64_t in_features, int64_t out_features) {
  // PyTorch's nn.Linear default init, then g = |v| so the initial weight is v.
  const double bound = 1.0 / std::sqrt(static_cast<double>(in_features));
  direction = register_parameter("direction", torch::empty({out_features, in_features}).uniform_(-bound, bound));
  magnitude = register_parameter("magnitude", direction.detach().norm(2, 1, true).clone());
  bias = register_parameter("bias", torch::empty({out_features}).uniform_(-bound, bound));
}

torch::Tensor WeightNormLinearImpl::weight() const {
  return direction * (magnitude / direction.norm(2, 1, true));
}

torch::Tensor WeightNormLinearImpl::forward(const torch::Tensor& x) { return torch::linear(x, weight(), bias); }

void WeightNormLinearImpl::reset(const torch::Tensor& weight, const torch::Tensor& b) {
  torch::NoGradGuard no_grad;
  direction.copy_(weight);
  // A zero row would make v / |v| undefined; keep its direction tiny but nonzero.
  magnitude.copy_(weight.norm(2, 1, true));
  direction.add_((magnitude == 0).to(direction.dtype()) * 1e-12);
  bias.copy_(b);
}

MlpImpl::MlpImpl(const MlpOptions& o) : options_(o) {
  FSKIN_CHECK(o.input_dim > 0 && o.output_dim > 0 && o.hidden_dim > 0 && o.hidden_layers >= 0,
              "Mlp: dimensions must be positive (input {}, output {}, hidden {} x {})", o.input_dim,
              o.output_dim, o.hidden_layers, o.hidden_dim);
  FSKIN_CHECK(o.condition_dim >= 0 && o.condition_layer >= 0 && o.condition_layer <= o.hidden_layers,
              "Mlp: condition layer {} must be in 0..{}", o.condition_layer, o.hidden_layers);
  const int64_t num_linear = o.hidden_layers + 1;
  auto is_skip = [&](int64_t l) {
    return std::find(o.skip_layers.begin(), o.skip_layers.end(), l) != o.skip_layers.end();
  };
  for (int64_t l : o.skip_layers) {
    FSKIN_CHECK(l >= 1 && l < num_linear, "Mlp: skip layer {} must be in 1..{}", l, num_linear - 1);
  }
  for (int64_t l = 0; l < num_linear; ++l) {
    // Layer inputs keep the hidden width: the layer feeding a skip narrows its
    // output by input_dim so that concatenating the input restores it (IDR).
    int64_t in = l == 0 ? o.input_dim : o.hidden_dim;
    if (o.condition_dim > 0 && l == o.condition_layer) in += o.condition_dim;
    int64_t out = l + 1 == num_linear ? o.output_dim : o.hidden_dim;
    if (is_skip(l + 1)) out -= o.input_dim;
    FSKIN_CHECK(out > 0, "Mlp: hidden_dim {} too small for a skip of input_dim {}", o.hidden_dim, o.input_dim);
    auto layer = register_module("linear" + std::to_string(l), WeightNormLinear(in, out));
    if (o.geometric_init) {
      torch::Tensor w;
      torch::Tensor b = torch::zeros({out});
      if (l + 1 == num_linear) {
        // Negative slope times |h| plus radius: positive (occupied) inside the sphere.
        w = torch::randn({out, in}) * 1e-4 - std::sqrt(M_PI) / std::sqrt(static_cast<double>(in));
        b.fill_(o.geometric_init_radius);
      } else {
        w = torch::randn({out, in}) * (std::sqrt(2.0) / std::sqrt(static_cast<double>(out)));
        // Only the 3 coordinates drive the initial field: zero the columns of
        // extra input features (encodings) and of the condition.
        auto zero_columns = [&](int64_t from, int64_t to) {
          if (to > from) w.narrow(1, from, to - from).zero_();
        };
        if (l == 0) zero_columns(3, o.input_dim);
        if (is_skip(l)) zero_columns(o.hidden_dim - o.input_dim + 3, o.hidden_dim);
        if (o.condition_dim > 0 && l == o.condition_layer) zero_columns(in - o.condition_dim, in);
      }
      layer->reset(w, b);
    }
    if (o.zero_output_init && l + 1 == num_linear) layer->reset(torch::zeros({out, in}), torch::zeros({out}));
    layers_.push_back(layer);
  }
}

torch::Tensor MlpImpl::forward(const torch::Tensor& x, const torch::Tensor& condition) {
  FSKIN_CHECK(x.dim() >= 1 && x.size(-1) == options_.input_dim, "Mlp: input must be [..., {}], got {}",
              options_.input_dim, shape_string(x.sizes()));
  if (options_.condition_dim > 0) {
    FSKIN_CHECK(condition.defined() && condition.size(-1) == options_.condition_dim,
                "Mlp: condition must be [..., {}]", options_.condition_dim);
  }
  const double inv_sqrt2 = 1.0 / std::sqrt(2.0);
  torch::Tensor h = x;
  const int64_t num_linear = static_cast<int64_t>(layers_.size());
  for (int64_t l = 0; l < num_linear; ++l) {
    if (std::find(options_.skip_layers.begin(), options_.skip_layers.end(), l) != options_.skip_layers.end()) {
      h = torch::cat({h, x}, -1) * inv_sqrt2;
    }
    if (options_.condition_dim > 0 && l == options_.condition_layer) h = torch::cat({h, condition}, -1);
    h = layers_[l]->forward(h);
    if (l + 1 < num_linear) h = torch::softplus(h, options_.softplus_beta, 20.0);
  }
  return h;
}

}  // namespace fskin
