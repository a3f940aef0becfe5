#pragma once
// Back-D (SNARF sec. 4.2): a displacement field in posed space, conditioned on
// the pose, moves each posed point (in the root bone's frame) to canonical
// space: x = x'_root + D(x'_root, p). The last layer starts at zero, so the
// warp starts as the rigid root transform.
#include "fskin/baselines/backward_warp_model.h"
#include "fskin/networks/input_normalization.h"
#include "fskin/networks/mlp.h"

namespace fskin {

struct BackwardDisplacementOptions {
  int64_t num_bones = 24;
  int64_t hidden_dim = 128;
  int64_t hidden_layers = 4;
  InputNormalization input;  // root-frame posed points -> network coordinates
};

class BackwardDisplacementModel : public BackwardWarpModel {
 public:
  BackwardDisplacementModel(const OccupancyNetworkOptions& occupancy, const BackwardDisplacementOptions& options);

 protected:
  torch::Tensor to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                             const torch::Tensor& pose) override;

 private:
  BackwardDisplacementOptions options_;
  Mlp displacement_{nullptr};
};

}  // namespace fskin
