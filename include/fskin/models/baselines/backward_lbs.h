#pragma once
// Back-LBS (SNARF sec. 4.2): skinning weights predicted in posed space from the
// posed point and the pose, w(x', p); the canonical point is found by
// inverting the blended transform: x = (sum_j w_j B_j)^-1 x'.
#include "fskin/models/baselines/backward_warp_model.h"

namespace fskin {

class BackwardLbsModel : public BackwardWarpModel {
 public:
  BackwardLbsModel(const OccupancyNetworkOptions& occupancy, const BackwardWarpOptions& options);

 protected:
  torch::Tensor to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                             const torch::Tensor& pose) override;

 private:
  static constexpr double kSoftmaxScale = 20.0;  // as the forward skinning field
  BackwardWarpOptions options_;
  Mlp weights_{nullptr};
};

}  // namespace fskin
