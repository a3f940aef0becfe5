#pragma once
// The backward baselines of SNARF sec. 4.2: a network in *posed* space maps
// each posed point to one canonical point, where a canonical occupancy
// network (the same as SNARF's) is evaluated. Because the warp lives in posed
// space and is conditioned on the pose, it must learn every pose it meets, so
// it generalises poorly to unseen poses; SNARF's forward skinning does not.
// Subclasses define the warp (backward_lbs.h, backward_displacement.h).
#include "fskin/canonical/occupancy_network.h"
#include "fskin/training/occupancy_model.h"

namespace fskin {

class BackwardWarpModel : public OccupancyModel {
 public:
  OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones, const torch::Tensor& pose,
                              Aggregation aggregation) override;
  // Bone occupancy only: the warp has no canonical skinning weights to bootstrap.
  torch::Tensor bootstrap_loss(const BootstrapInputs& inputs) override;
  bool has_canonical_shape() const override { return true; }
  torch::Tensor canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) override;

 protected:
  explicit BackwardWarpModel(const OccupancyNetworkOptions& occupancy);
  // Posed points [B, N, 3] -> one canonical point each [B, N, 3].
  virtual torch::Tensor to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                                     const torch::Tensor& pose) = 0;

 private:
  OccupancyNetworkOptions occupancy_options_;
  OccupancyNetwork occupancy_{nullptr};
};

}  // namespace fskin
