#include "fskin/baselines/backward_lbs.h"

#include "fskin/core/error.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {

BackwardLbsModel::BackwardLbsModel(const OccupancyNetworkOptions& occupancy, const BackwardLbsOptions& options)
    : BackwardWarpModel(occupancy), options_(options) {
  FSKIN_CHECK(options.num_bones >= 2, "back-lbs: needs >= 2 bones, got {}", options.num_bones);
  MlpOptions mlp;
  mlp.input_dim = 3;
  mlp.output_dim = options.num_bones;
  mlp.hidden_dim = options.hidden_dim;
  mlp.hidden_layers = options.hidden_layers;
  mlp.condition_dim = 3 * (options.num_bones - 1);  // the pose condition, at the input
  mlp.condition_layer = 0;
  weights_ = register_module("weights", Mlp(mlp));
}

torch::Tensor BackwardLbsModel::to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                                             const torch::Tensor& pose) {
  FSKIN_CHECK(bones.size(1) == options_.num_bones, "back-lbs: {} bones, the model has {}", bones.size(1),
              options_.num_bones);
  const auto local = options_.input.apply(to_root_frame(points, bones));
  const auto condition = pose_condition(pose).to(points.dtype()).unsqueeze(1).expand({-1, points.size(1), -1});
  const auto w = torch::softmax(weights_->forward(local, condition) * options_.softmax_scale, -1);  // [B, N, J]
  // Solve (sum_j w_j B_j) x = x' rather than forming the inverse: the blend of
  // rotations can be near-singular where the weights are mixed.
  const auto blended = blend_transforms(w, bones.to(points.dtype()));  // [B, N, 4, 4]
  const auto A = blended.narrow(-2, 0, 3).narrow(-1, 0, 3);
  const auto t = blended.narrow(-2, 0, 3).select(-1, 3);
  return torch::linalg_solve(A, (points - t).unsqueeze(-1)).squeeze(-1);
}

}  // namespace fskin
