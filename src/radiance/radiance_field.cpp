#include "fskin/radiance/radiance_field.h"

#include <algorithm>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/networks/relu_mlp.h"

namespace fskin {

void RadianceFieldOptions::validate() const {
  encoding.validate();
  FSKIN_CHECK(hidden_dim >= 1 && hidden_dim <= 4096, "radiance field: hidden_dim must be within 1..4096, got {}",
              hidden_dim);
  FSKIN_CHECK(hidden_layers >= 1 && hidden_layers <= 16, "radiance field: hidden_layers must be within 1..16, got {}",
              hidden_layers);
  FSKIN_CHECK(shading == "none" || shading == "lambert", "radiance field: shading must be none or lambert, got '{}'",
              shading);
  FSKIN_CHECK(appearance_dim >= 0 && appearance_dim <= 1024,
              "radiance field: appearance_dim must be within 0..1024, got {}", appearance_dim);
  FSKIN_CHECK(appearance_hidden_dim >= 1 && appearance_hidden_dim <= 4096,
              "radiance field: appearance_hidden_dim must be within 1..4096, got {}", appearance_hidden_dim);
}

RadianceFieldImpl::RadianceFieldImpl(RadianceFieldOptions options, std::array<double, 3> lower,
                                     std::array<double, 3> upper)
    : options_(std::move(options)), lower_(lower), upper_(upper) {
  options_.validate();
  extent_ = 0;
  for (int c = 0; c < 3; ++c) {
    FSKIN_CHECK(std::isfinite(lower[c]) && std::isfinite(upper[c]) && upper[c] > lower[c],
                "radiance field: the canonical box must be finite and non-empty along every axis");
    extent_ = std::max(extent_, upper[c] - lower[c]);
  }
  table_ = register_parameter("table", hash_encoding_table(options_.encoding));
  // Density and colour from the encoded point (eq. 18-19).
  const int64_t outputs = options_.lambert() ? 7 : 4;  // sigma, albedo (, n)
  mlp_ = register_module("mlp", relu_mlp({options_.encoding.output_dim(), outputs, options_.hidden_dim,
                                          options_.hidden_layers}));
  if (options_.appearance_dim > 0) {
    appearance_mlp_ = register_module(
        "appearance_mlp", relu_mlp({options_.encoding.output_dim() + options_.appearance_dim, 3,
                                    options_.appearance_hidden_dim, 1}));
    // The output layer (entry 2) at zero: training starts from the colour without codes.
    torch::NoGradGuard no_grad;
    for (auto& p : appearance_mlp_[2]->parameters()) p.zero_();
  }
  if (options_.lambert()) {
    // A light from above-front, and a = softplus(0.5) ~ 0.97 so that the
    // first colours are about the albedo; the field learns both.
    light_ = register_parameter("light", torch::tensor({0.0f, 0.5f, 0.5f}));
    ambient_ = register_parameter("ambient", torch::tensor(0.5f));
  }
}

RadianceSample RadianceFieldImpl::forward(const torch::Tensor& x, const torch::Tensor& rotations,
                                          const torch::Tensor& appearance) {
  expect_shape(x, {-1, 3}, "radiance field: points");
  const auto lower = torch::tensor({lower_[0], lower_[1], lower_[2]}, x.options());
  const auto upper = torch::tensor({upper_[0], upper_[1], upper_[2]}, x.options());
  // Normalised by the longest side: the box's lower corner at 0, cubic cells.
  const auto unit = (x - lower) / extent_;
  const auto inside = ((x >= lower) & (x <= upper)).all(1);
  const auto features = hash_encoding(unit.to(table_.scalar_type()), table_, options_.encoding);
  const auto raw = mlp_->forward(features);
  // Density per unit length relative to the box: exp keeps it positive with a
  // useful gradient at any scale; sigma * step is then the same for a
  // character of any size. Clamped so that exp cannot overflow.
  const auto sigma = torch::exp(raw.select(1, 0).clamp(-15, 15)) / extent_ * inside.to(raw.scalar_type());
  auto logits = raw.slice(1, 1, 4);
  if (appearance_mlp_) {
    const int64_t D = options_.appearance_dim;
    torch::Tensor code = appearance.defined() ? appearance : torch::zeros({D});
    expect_shape(code, {D}, "radiance field: appearance code");
    code = code.to(features.options()).unsqueeze(0).expand({features.size(0), D});
    logits = logits + appearance_mlp_->forward(torch::cat({features, code}, 1));
  }
  auto rgb = torch::sigmoid(logits);
  if (options_.lambert() && rotations.defined()) {
    expect_shape(rotations, {x.size(0), 3, 3}, "radiance field: rotations");
    const auto posed_normal = torch::matmul(rotations.to(raw.scalar_type()), raw.slice(1, 4, 7).unsqueeze(2)).squeeze(2);
    const auto shade = torch::softplus(ambient_) + torch::relu(torch::matmul(posed_normal, light_));
    rgb = rgb * shade.unsqueeze(1);
  }
  return {sigma, rgb};
}

}  // namespace fskin
