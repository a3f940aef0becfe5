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

torch::Tensor OperationMapImpl::evaluate(torch::Tensor h) {
  h = torch::softplus(h, kSoftplusBeta, 20.0);
  for (auto& layer : hidden_) h = torch::softplus(layer->forward(h), kSoftplusBeta, 20.0);
  return last_->forward(h);
}

FoldedFirstLayer OperationMapImpl::fold(const torch::Tensor& pose, const SpaceProjection& projection) {
  // W_a diag(z_p) [B, hidden, E], then (with a projection) times P.
  const auto& w_a = first_space_pose_->weight;
  FoldedFirstLayer out;
  out.weight = w_a.unsqueeze(0) * pose.unsqueeze(1);
  out.bias = first_pose_->forward(pose) + first_space_pose_->bias;  // W_b z_p + b [B, hidden]
  if (projection.weight.defined()) {
    out.weight = torch::matmul(out.weight, projection.weight);
    out.bias = out.bias + torch::matmul(pose * projection.bias, w_a.t());
  }
  return out;
}

torch::Tensor OperationMapImpl::at_zero_conditioning() {
  return evaluate(first_space_pose_->bias.view({1, -1})).view({-1});
}

torch::Tensor OperationMapImpl::forward(const torch::Tensor& space, const torch::Tensor& pose,
                                        const SpaceProjection& projection) {
  const int64_t e = options_.embedding_dim;
  const bool projected = projection.weight.defined();
  if (projected) {
    expect_shape(projection.weight, {e, -1}, "OperationMap: space projection weight");
    expect_shape(projection.bias, {e}, "OperationMap: space projection bias");
  }
  expect_shape(space, {-1, -1, projected ? projection.weight.size(1) : e},
               projected ? "OperationMap: space features" : "OperationMap: space embedding");
  expect_shape(pose, {space.size(0), e}, "OperationMap: pose embedding");
  const auto folded = fold(pose, projection);
  const auto pre_activation = torch::matmul(space, folded.weight.transpose(1, 2)) + folded.bias.unsqueeze(1);
  // Centring: at z_p = 0 the pre-activation is b for every point.
  return evaluate(pre_activation) - at_zero_conditioning();
}

}  // namespace fskin
