#include "fskin/gaussians/gaussian_appearance.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/networks/frequency_encoding.h"

namespace fskin {

void GaussianAppearanceOptions::validate() const {
  FSKIN_CHECK(dim >= 0 && dim <= 1024, "gaussian avatar: model.appearance.dim must be within 0..1024, got {}", dim);
  FSKIN_CHECK(hidden >= 1 && hidden <= 4096, "gaussian avatar: model.appearance.hidden must be within 1..4096, got {}",
              hidden);
  FSKIN_CHECK(frequencies >= 0 && frequencies <= 16,
              "gaussian avatar: the appearance's frequencies must be within 0..16, got {}", frequencies);
}

GaussianAppearanceImpl::GaussianAppearanceImpl(const torch::Tensor& box_low, const torch::Tensor& box_high,
                                               const GaussianAppearanceOptions& options)
    : options_(options) {
  options_.validate();
  FSKIN_CHECK(options_.dim >= 1, "gaussian avatar: an appearance network needs a code length of at least 1");
  box_low_ = register_buffer("box_low", box_low.to(torch::kFloat32).reshape({3}));
  box_high_ = register_buffer("box_high", box_high.to(torch::kFloat32).reshape({3}));
  position_ = register_module("position", torch::nn::Linear(3 + 6 * options_.frequencies, options_.hidden));
  code_ = register_module("code",
                          torch::nn::Linear(torch::nn::LinearOptions(options_.dim, options_.hidden).bias(false)));
  out_ = register_module("out", torch::nn::Linear(options_.hidden, 3));
  torch::NoGradGuard no_grad;
  out_->weight.zero_();
  out_->bias.zero_();
}

torch::Tensor GaussianAppearanceImpl::forward(const torch::Tensor& means, const torch::Tensor& code) {
  expect_shape(means, {-1, 3}, "gaussian appearance: means");
  auto h = position_->forward(
      positional_encoding((means - box_low_) / (box_high_ - box_low_).clamp_min(1e-12) * 2 - 1, options_.frequencies));
  if (code.defined()) {
    expect_shape(code, {options_.dim}, "gaussian appearance: code");
    h = h + code_->forward(code.to(means.options()).reshape({1, -1}));  // [1, hidden], once per frame
  }
  return out_->forward(torch::relu(h));
}

}  // namespace fskin
