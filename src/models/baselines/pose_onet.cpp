#include "fskin/models/baselines/pose_onet.h"

#include "fskin/core/error.h"
#include "fskin/models/pose_condition.h"
#include "fskin/util/stopwatch.h"

namespace fskin {

PoseOnetModel::PoseOnetModel(const OccupancyNetworkOptions& occupancy) {
  FSKIN_CHECK(occupancy.pose_dim > 0, "pose-onet: the network needs the pose as input (pose_dim = 0)");
  network_ = register_module("occupancy", OccupancyNetwork(occupancy));
}

OccupancyPrediction PoseOnetModel::predict(const torch::Tensor& points, const torch::Tensor& bones,
                                           const torch::Tensor& pose, Aggregation) {
  OccupancyPrediction out;
  Stopwatch watch;
  const auto local = to_root_frame(points, bones);
  out.deformer_seconds = watch.lap();
  out.logits = network_->forward(local, pose_condition(pose).to(points.dtype()));
  out.shape_seconds = watch.lap();
  return out;
}

}  // namespace fskin
