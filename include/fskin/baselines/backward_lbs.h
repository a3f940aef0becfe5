#pragma once
// Back-LBS (SNARF sec. 4.2): skinning weights predicted in posed space from the
// posed point and the pose, w(x', p); the canonical point is found by
// inverting the blended transform: x = (sum_j w_j B_j)^-1 x'.
#include "fskin/baselines/backward_warp_model.h"
#include "fskin/networks/input_normalization.h"
#include "fskin/networks/mlp.h"

namespace fskin {

struct BackwardLbsOptions {
  int64_t num_bones = 24;
  int64_t hidden_dim = 128;
  int64_t hidden_layers = 4;
  double softmax_scale = 20.0;  // as the forward skinning field
  InputNormalization input;     // root-frame posed points -> network coordinates
};

class BackwardLbsModel : public BackwardWarpModel {
 public:
  BackwardLbsModel(const OccupancyNetworkOptions& occupancy, const BackwardLbsOptions& options);

 protected:
  torch::Tensor to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                             const torch::Tensor& pose) override;

 private:
  BackwardLbsOptions options_;
  Mlp weights_{nullptr};
};

}  // namespace fskin
