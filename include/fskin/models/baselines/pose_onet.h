#pragma once
// Pose-ONet (SNARF sec. 4.2): no deformation model at all; one occupancy
// network of posed points, conditioned on the pose. It has to learn every
// pose's shape from examples, so it does not generalise to unseen poses: the
// gap SNARF's Table 1 measures.
#include "fskin/canonical/occupancy_network.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

class PoseOnetModel : public OccupancyModel {
 public:
  // occupancy.pose_dim must be 3 (J - 1) (the pose condition's width).
  explicit PoseOnetModel(const OccupancyNetworkOptions& occupancy);
  OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones, const torch::Tensor& pose,
                              Aggregation aggregation) override;
  void set_frequency_window(double window) override { network_->set_frequency_window(window); }

 private:
  OccupancyNetwork network_{nullptr};
};

}  // namespace fskin
