#include "fskin/models/baselines/backward_warp_model.h"

#include "fskin/core/error.h"
#include "fskin/models/pose_condition.h"
#include "fskin/util/stopwatch.h"

namespace fskin {

BackwardWarpModel::BackwardWarpModel(const OccupancyNetworkOptions& occupancy) : occupancy_options_(occupancy) {
  occupancy_ = register_module("occupancy", OccupancyNetwork(occupancy));
}

MlpOptions BackwardWarpModel::warp_mlp_options(const BackwardWarpOptions& options, int64_t output_dim) {
  FSKIN_CHECK(options.num_bones >= 2, "backward warp: needs >= 2 bones, got {}", options.num_bones);
  MlpOptions mlp;
  mlp.input_dim = 3;
  mlp.output_dim = output_dim;
  mlp.hidden_dim = options.hidden_dim;
  mlp.hidden_layers = options.hidden_layers;
  mlp.condition_dim = 3 * (options.num_bones - 1);
  mlp.condition_layer = 0;
  return mlp;
}

torch::Tensor BackwardWarpModel::pointwise_condition(const torch::Tensor& pose, const torch::Tensor& points) {
  return pose_condition(pose).to(points.dtype()).unsqueeze(1).expand({-1, points.size(1), -1});
}

OccupancyPrediction BackwardWarpModel::predict(const torch::Tensor& points, const torch::Tensor& bones,
                                               const torch::Tensor& pose, Aggregation) {
  OccupancyPrediction out;
  Stopwatch watch(points.is_cuda());
  const auto x = to_canonical(points, bones, pose);
  out.deformer_seconds = watch.lap();
  out.logits = canonical_logits(x, pose);  // one candidate: nothing to aggregate
  out.shape_seconds = watch.lap();
  return out;
}

torch::Tensor BackwardWarpModel::canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) {
  if (occupancy_options_.pose_dim == 0) return occupancy_->forward(x_canonical);
  return occupancy_->forward(x_canonical, pose_condition(pose).to(x_canonical.dtype()));
}

}  // namespace fskin
