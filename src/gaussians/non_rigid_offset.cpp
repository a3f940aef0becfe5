#include "fskin/gaussians/non_rigid_offset.h"

#include <algorithm>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/networks/frequency_encoding.h"

namespace fskin {

NonRigidOffsetImpl::NonRigidOffsetImpl(int64_t joints, const torch::Tensor& box_low, const torch::Tensor& box_high,
                                       double size, const NonRigidOffsetOptions& options)
    : options_(options), joints_(joints), size_(size) {
  FSKIN_CHECK(options.frequencies >= 0 && options.frequencies <= 16,
              "non-rigid offset: frequencies must be within 0..16, got {}", options.frequencies);
  FSKIN_CHECK(options.hidden >= 1 && options.hidden <= 4096, "non-rigid offset: hidden must be within 1..4096, got {}",
              options.hidden);
  FSKIN_CHECK(joints >= 1 && size > 0, "non-rigid offset: needs a skeleton and a positive size");
  box_low_ = register_buffer("box_low", box_low.to(torch::kFloat32).reshape({3}));
  box_high_ = register_buffer("box_high", box_high.to(torch::kFloat32).reshape({3}));
  const int64_t encoded = 3 + 6 * options.frequencies;
  position_ = register_module("position", torch::nn::Linear(encoded, options.hidden));
  // A one-joint skeleton has no relative rotation: one zero feature row stands in.
  pose_ = register_module(
      "pose", torch::nn::Linear(torch::nn::LinearOptions(9 * std::max<int64_t>(joints - 1, 1), options.hidden).bias(false)));
  hidden_ = register_module("hidden", torch::nn::Linear(options.hidden, options.hidden));
  out_ = register_module("out", torch::nn::Linear(options.hidden, 3));
  torch::NoGradGuard no_grad;
  out_->weight.zero_();
  out_->bias.zero_();
}

torch::Tensor NonRigidOffsetImpl::forward(const torch::Tensor& means, const torch::Tensor& bones) {
  expect_shape(means, {-1, 3}, "non-rigid offset: means");
  expect_shape(bones, {joints_, 4, 4}, "non-rigid offset: bone transforms");
  // [-1, 1] across the box.
  const auto unit = (means - box_low_) / (box_high_ - box_low_).clamp_min(1e-12) * 2 - 1;
  const auto rotations = bones.to(means.options()).narrow(1, 0, 3).narrow(2, 0, 3);  // [J, 3, 3]
  const auto relative =
      joints_ == 1 ? torch::zeros({1, 3, 3}, means.options())
                   : torch::matmul(rotations[0].t().unsqueeze(0), rotations.narrow(0, 1, joints_ - 1)) -
                         torch::eye(3, means.options()).unsqueeze(0);
  const auto pose_bias = pose_->forward(relative.reshape({1, -1}));  // [1, hidden], once per frame
  auto h = torch::relu(position_->forward(positional_encoding(unit, options_.frequencies)) + pose_bias);
  h = torch::relu(hidden_->forward(h));
  return out_->forward(h) * size_;
}

}  // namespace fskin
