#include "fskin/baselines/backward_warp_model.h"

#include "fskin/training/bootstrap_losses.h"
#include "fskin/util/stopwatch.h"

namespace fskin {

BackwardWarpModel::BackwardWarpModel(const OccupancyNetworkOptions& occupancy) : occupancy_options_(occupancy) {
  occupancy_ = register_module("occupancy", OccupancyNetwork(occupancy));
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

torch::Tensor BackwardWarpModel::bootstrap_loss(const BootstrapInputs& inputs) {
  return bone_occupancy_loss(*this, inputs.bone_points, inputs.pose);
}

torch::Tensor BackwardWarpModel::canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) {
  if (occupancy_options_.pose_dim == 0) return occupancy_->forward(x_canonical);
  return occupancy_->forward(x_canonical, pose_condition(pose).to(x_canonical.dtype()));
}

}  // namespace fskin
