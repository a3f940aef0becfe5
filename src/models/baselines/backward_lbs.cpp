#include "fskin/models/baselines/backward_lbs.h"

#include "fskin/core/error.h"
#include "fskin/models/pose_condition.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {

BackwardLbsModel::BackwardLbsModel(const OccupancyNetworkOptions& occupancy, const BackwardWarpOptions& options)
    : BackwardWarpModel(occupancy), options_(options) {
  weights_ = register_module("weights", Mlp(warp_mlp_options(options, options.num_bones)));
}

torch::Tensor BackwardLbsModel::to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                                             const torch::Tensor& pose) {
  FSKIN_CHECK(bones.size(1) == options_.num_bones, "back-lbs: {} bones, the model has {}", bones.size(1),
              options_.num_bones);
  const auto local = options_.input.apply(to_root_frame(points, bones));
  const auto w = torch::softmax(weights_->forward(local, pointwise_condition(pose, points)) * kSoftmaxScale, -1);
  // Solve (sum_j w_j B_j) x = x' rather than forming the inverse: the blend of
  // rotations can be near-singular where the weights are mixed.
  const auto blended = blend_transforms(w, bones.to(points.dtype()));  // [B, N, 4, 4]
  const auto A = blended.narrow(-2, 0, 3).narrow(-1, 0, 3);
  const auto t = blended.narrow(-2, 0, 3).select(-1, 3);
  return torch::linalg_solve(A, (points - t).unsqueeze(-1)).squeeze(-1);
}

}  // namespace fskin
