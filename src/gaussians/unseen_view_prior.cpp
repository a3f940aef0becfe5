#include "fskin/gaussians/unseen_view_prior.h"

namespace fskin {

PinholeCamera unseen_view(const PinholeCamera& camera, double radians, const Eigen::Vector3d& pivot) {
  return camera.turned(camera.down(), radians, pivot);
}

torch::Tensor alpha_entropy_sum(const torch::Tensor& alpha) {
  const auto a = alpha.clamp(1e-4, 1 - 1e-4);
  return -(a * a.log() + (1 - a) * (1 - a).log()).sum();
}

}  // namespace fskin
