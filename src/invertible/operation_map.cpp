#include "fskin/invertible/operation_map.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

void OperationMapOptions::validate() const {
  FSKIN_CHECK(embedding_dim > 0, "OperationMapOptions: embedding_dim must be positive, got {}", embedding_dim);
  FSKIN_CHECK(hidden_dim > 0, "OperationMapOptions: hidden_dim must be positive, got {}", hidden_dim);
  FSKIN_CHECK(hidden_layers >= 1, "OperationMapOptions: hidden_layers must be >= 1, got {}", hidden_layers);
  FSKIN_CHECK(output_dim > 0, "OperationMapOptions: output_dim must be positive, got {}", output_dim);
}

OperationMapImpl::OperationMapImpl(const OperationMapOptions& o) : options_(o) {
  o.validate();
  // Default Linear init for W_a and W_b as for one Linear(2E, h): bound 1/sqrt(2E).
  const double bound = 1.0 / std::sqrt(2.0 * static_cast<double>(o.embedding_dim));
  first_space_pose_ = register_module("first_space_pose", torch::nn::Linear(o.embedding_dim, o.hidden_dim));
  first_pose_ = register_module("first_pose",
                                torch::nn::Linear(torch::nn::LinearOptions(o.embedding_dim, o.hidden_dim).bias(false)));
  for (int64_t l = 1; l < o.hidden_layers; ++l) {
    hidden_.push_back(register_module("hidden" + std::to_string(l), torch::nn::Linear(o.hidden_dim, o.hidden_dim)));
  }
  last_ = register_module("last", torch::nn::Linear(torch::nn::LinearOptions(o.hidden_dim, o.output_dim).bias(false)));
  torch::NoGradGuard no_grad;
  first_space_pose_->weight.uniform_(-bound, bound);
  first_space_pose_->bias.uniform_(-bound, bound);
  first_pose_->weight.uniform_(-bound, bound);
  last_->weight.zero_();
}

torch::Tensor OperationMapImpl::evaluate(const torch::Tensor& space_pose, const torch::Tensor& pose) {
  auto h = torch::softplus(first_space_pose_->forward(space_pose) + first_pose_->forward(pose).unsqueeze(-2),
                           100.0, 20.0);
  for (auto& layer : hidden_) h = torch::softplus(layer->forward(h), 100.0, 20.0);
  return last_->forward(h);
}

torch::Tensor OperationMapImpl::forward(const torch::Tensor& space_pose, const torch::Tensor& pose) {
  const int64_t e = options_.embedding_dim;
  expect_shape(space_pose, {-1, -1, e}, "OperationMap: space-pose embedding");
  expect_shape(pose, {space_pose.size(0), e}, "OperationMap: pose embedding");
  const auto zero_pose = torch::zeros({1, e}, pose.options());
  return evaluate(space_pose, pose) - evaluate(zero_pose.unsqueeze(1), zero_pose);
}

}  // namespace fskin
