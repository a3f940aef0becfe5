#include "fskin/models/baselines/piecewise_rigid.h"

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/models/occupancy_aggregation.h"
#include "fskin/util/stopwatch.h"

namespace fskin {

PiecewiseRigidModel::PiecewiseRigidModel(const PiecewiseRigidOptions& options) : options_(options) {
  FSKIN_CHECK(options.num_bones >= 1 && options.hidden_dim >= 1 && options.hidden_layers >= 1,
              "piecewise: bones ({}), hidden size ({} x {}) must be positive", options.num_bones,
              options.hidden_layers, options.hidden_dim);
  const int64_t J = options.num_bones;
  for (int64_t l = 0; l <= options.hidden_layers; ++l) {
    const int64_t in = l == 0 ? 3 : options.hidden_dim;
    const int64_t out = l == options.hidden_layers ? 1 : options.hidden_dim;
    // nn.Linear's default init, per part.
    const double bound = 1.0 / std::sqrt(static_cast<double>(in));
    weights_.push_back(register_parameter("weight" + std::to_string(l),
                                          torch::empty({J, in, out}).uniform_(-bound, bound)));
    biases_.push_back(register_parameter("bias" + std::to_string(l), torch::empty({J, out}).uniform_(-bound, bound)));
  }
}

torch::Tensor PiecewiseRigidModel::part_logits(const torch::Tensor& x) {
  expect_shape(x, {-1, -1, options_.num_bones, 3}, "piecewise: part points");
  auto h = options_.input.apply(x);
  const size_t layers = weights_.size();
  for (size_t l = 0; l < layers; ++l) {
    h = torch::einsum("bnji,jio->bnjo", {h, weights_[l]}) + biases_[l];
    if (l + 1 < layers) h = torch::softplus(h, 100.0, 20.0);
  }
  return h.squeeze(-1);
}

OccupancyPrediction PiecewiseRigidModel::predict(const torch::Tensor& points, const torch::Tensor& bones,
                                                 const torch::Tensor&, Aggregation aggregation) {
  expect_shape(points, {-1, -1, 3}, "piecewise: points");
  expect_shape(bones, {points.size(0), options_.num_bones, 4, 4}, "piecewise: bones");
  OccupancyPrediction out;
  Stopwatch watch(points.is_cuda());
  const auto inverse = invert_transforms(bones.to(points.dtype()));               // [B, J, 4, 4]
  const auto x = transform_points(inverse.unsqueeze(1), points.unsqueeze(2));   // [B, N, J, 3]
  out.deformer_seconds = watch.lap();
  const auto logits = part_logits(x);
  out.shape_seconds = watch.lap();
  const auto all = torch::ones_like(logits, torch::kBool);
  out.logits = aggregation == Aggregation::Soft ? soft_max_occupancy(logits, all) : hard_max_occupancy(logits, all);
  out.aggregation_seconds = watch.lap();
  return out;
}

}  // namespace fskin
