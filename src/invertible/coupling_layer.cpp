#include "fskin/invertible/coupling_layer.h"

#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

void CouplingLayerOptions::validate() const {
  FSKIN_CHECK(embedding_dim > 0, "CouplingLayerOptions: embedding_dim must be positive, got {}", embedding_dim);
  FSKIN_CHECK(space_hidden_dim > 0, "CouplingLayerOptions: space_hidden_dim must be positive, got {}",
              space_hidden_dim);
  FSKIN_CHECK(space_layers >= 1, "CouplingLayerOptions: space_layers must be >= 1, got {}", space_layers);
  FSKIN_CHECK(std::isfinite(first_omega) && first_omega > 0,
              "CouplingLayerOptions: first_omega must be positive, got {}", first_omega);
  FSKIN_CHECK(std::isfinite(hidden_omega) && hidden_omega > 0,
              "CouplingLayerOptions: hidden_omega must be positive, got {}", hidden_omega);
  FSKIN_CHECK(map_hidden_dim > 0, "CouplingLayerOptions: map_hidden_dim must be positive, got {}", map_hidden_dim);
  FSKIN_CHECK(map_hidden_layers >= 1, "CouplingLayerOptions: map_hidden_layers must be >= 1, got {}",
              map_hidden_layers);
}

CouplingLayer::CouplingLayer(std::vector<int64_t> moved, const CouplingLayerOptions& options)
    : moved_(std::move(moved)), options_(options) {
  options.validate();
  for (int64_t axis : moved_) {
    FSKIN_CHECK(axis >= 0 && axis < 3, "CouplingLayer: axis {} is not 0 (x), 1 (y) or 2 (z)", axis);
  }
  for (int64_t axis = 0; axis < 3; ++axis) {
    if (std::find(moved_.begin(), moved_.end(), axis) == moved_.end()) kept_.push_back(axis);
  }
  FSKIN_CHECK(kept_.size() + moved_.size() == 3, "CouplingLayer: moved axes must be distinct");
  SirenOptions siren;
  siren.input_dim = static_cast<int64_t>(kept_.size());
  siren.hidden_dim = options.space_hidden_dim;
  siren.output_dim = options.embedding_dim;
  siren.num_layers = options.space_layers;
  siren.first_omega = options.first_omega;
  siren.hidden_omega = options.hidden_omega;
  siren.linear_output = options.space_linear_output;
  space_embedding_ = register_module("space_embedding", Siren(siren));
}

OperationMapOptions CouplingLayer::map_options(int64_t output_dim) const {
  OperationMapOptions o;
  o.embedding_dim = options_.embedding_dim;
  o.hidden_dim = options_.map_hidden_dim;
  o.hidden_layers = options_.map_hidden_layers;
  o.output_dim = output_dim;
  return o;
}

torch::Tensor CouplingLayer::apply(const torch::Tensor& x, const torch::Tensor& pose_embedding, bool inverse) {
  expect_shape(x, {-1, -1, 3}, "CouplingLayer: points");
  expect_shape(pose_embedding, {x.size(0), options_.embedding_dim}, "CouplingLayer: pose embedding");
  std::vector<torch::Tensor> a, b;
  for (int64_t axis : moved_) a.push_back(x.select(-1, axis));
  for (int64_t axis : kept_) b.push_back(x.select(-1, axis));
  // Eq. 8-9: z_s from the kept coordinates, which forward and inverse share.
  const auto x_b = torch::stack(b, -1);
  Conditioning conditioning;
  conditioning.pose = pose_embedding;
  if (options_.space_linear_output) {
    conditioning.space = space_embedding_->hidden(x_b);
    const auto last = space_embedding_->output_layer();
    conditioning.projection = {last->weight, last->bias};
  } else {
    conditioning.space = space_embedding_->forward(x_b);
  }
  const auto y_a = transform(torch::stack(a, -1), conditioning, inverse);
  std::vector<torch::Tensor> columns(3);
  for (size_t i = 0; i < moved_.size(); ++i) columns[moved_[i]] = y_a.select(-1, static_cast<int64_t>(i));
  for (size_t i = 0; i < kept_.size(); ++i) columns[kept_[i]] = b[i];
  return torch::stack(columns, -1);
}

torch::Tensor CouplingLayer::forward(const torch::Tensor& x, const torch::Tensor& pose_embedding) {
  return apply(x, pose_embedding, false);
}

torch::Tensor CouplingLayer::inverse(const torch::Tensor& y, const torch::Tensor& pose_embedding) {
  return apply(y, pose_embedding, true);
}

CouplingLayer2D::CouplingLayer2D(int64_t first, int64_t second, const CouplingLayerOptions& options)
    : CouplingLayer({first, second}, options) {
  rotation_ = register_module("rotation", OperationMap(map_options(1)));
  translation_ = register_module("translation", OperationMap(map_options(2)));
}

torch::Tensor CouplingLayer2D::transform(const torch::Tensor& x_a, const Conditioning& conditioning, bool inverse) {
  const auto theta = evaluate(rotation_, conditioning).squeeze(-1);
  const auto t = evaluate(translation_, conditioning);
  const auto c = torch::cos(theta), s = torch::sin(theta);
  if (!inverse) {  // eq. 5: y_a = R x_a + t
    const auto u = x_a.select(-1, 0), v = x_a.select(-1, 1);
    return torch::stack({c * u - s * v, s * u + c * v}, -1) + t;
  }
  // eq. 6: x_a = R^T (y_a - t)
  const auto d = x_a - t;
  const auto u = d.select(-1, 0), v = d.select(-1, 1);
  return torch::stack({c * u + s * v, -s * u + c * v}, -1);
}

CouplingLayer1D::CouplingLayer1D(int64_t axis, const CouplingLayerOptions& options)
    : CouplingLayer({axis}, options) {
  translation_ = register_module("translation", OperationMap(map_options(1)));
}

torch::Tensor CouplingLayer1D::transform(const torch::Tensor& x_a, const Conditioning& conditioning, bool inverse) {
  const auto t = evaluate(translation_, conditioning);  // eq. 12
  return inverse ? x_a - t : x_a + t;
}

}  // namespace fskin
