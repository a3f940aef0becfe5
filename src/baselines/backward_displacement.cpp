#include "fskin/baselines/backward_displacement.h"

#include "fskin/core/error.h"

namespace fskin {

BackwardDisplacementModel::BackwardDisplacementModel(const OccupancyNetworkOptions& occupancy,
                                                     const BackwardDisplacementOptions& options)
    : BackwardWarpModel(occupancy), options_(options) {
  FSKIN_CHECK(options.num_bones >= 2, "back-d: needs >= 2 bones, got {}", options.num_bones);
  MlpOptions mlp;
  mlp.input_dim = 3;
  mlp.output_dim = 3;
  mlp.hidden_dim = options.hidden_dim;
  mlp.hidden_layers = options.hidden_layers;
  mlp.condition_dim = 3 * (options.num_bones - 1);  // the pose condition, at the input
  mlp.condition_layer = 0;
  mlp.zero_output_init = true;
  displacement_ = register_module("displacement", Mlp(mlp));
}

torch::Tensor BackwardDisplacementModel::to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                                                      const torch::Tensor& pose) {
  FSKIN_CHECK(bones.size(1) == options_.num_bones, "back-d: {} bones, the model has {}", bones.size(1),
              options_.num_bones);
  const auto local = to_root_frame(points, bones);
  const auto condition = pose_condition(pose).to(points.dtype()).unsqueeze(1).expand({-1, points.size(1), -1});
  return local + displacement_->forward(options_.input.apply(local), condition);
}

}  // namespace fskin
