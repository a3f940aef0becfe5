#pragma once
// Back-D (SNARF sec. 4.2): a displacement field in posed space, conditioned on
// the pose, moves each posed point (in the root bone's frame) to canonical
// space: x = x'_root + D(x'_root, p). The last layer starts at zero, so the
// warp starts as the rigid root transform.
#include "fskin/models/baselines/backward_warp_model.h"

namespace fskin {

class BackwardDisplacementModel : public BackwardWarpModel {
 public:
  BackwardDisplacementModel(const OccupancyNetworkOptions& occupancy, const BackwardWarpOptions& options);

 protected:
  torch::Tensor to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                             const torch::Tensor& pose) override;

 private:
  BackwardWarpOptions options_;
  Mlp displacement_{nullptr};
};

}  // namespace fskin
