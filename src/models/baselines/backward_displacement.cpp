#include "fskin/models/baselines/backward_displacement.h"

#include "fskin/core/error.h"
#include "fskin/models/pose_condition.h"

namespace fskin {

BackwardDisplacementModel::BackwardDisplacementModel(const OccupancyNetworkOptions& occupancy,
                                                     const BackwardWarpOptions& options)
    : BackwardWarpModel(occupancy), options_(options) {
  auto mlp = warp_mlp_options(options, 3);
  mlp.zero_output_init = true;
  displacement_ = register_module("displacement", Mlp(mlp));
}

torch::Tensor BackwardDisplacementModel::to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                                                      const torch::Tensor& pose) {
  FSKIN_CHECK(bones.size(1) == options_.num_bones, "back-d: {} bones, the model has {}", bones.size(1),
              options_.num_bones);
  const auto local = to_root_frame(points, bones);
  return local + displacement_->forward(options_.input.apply(local), pointwise_condition(pose, points));
}

}  // namespace fskin
