#include "fskin/gaussians/unseen_view_prior.h"

#include "fskin/gaussians/binary_entropy.h"

namespace fskin {

PinholeCamera unseen_view(const PinholeCamera& camera, double radians, const Eigen::Vector3d& pivot) {
  return camera.turned(camera.down(), radians, pivot);
}

torch::Tensor alpha_entropy_sum(const torch::Tensor& alpha) { return binary_entropy(alpha, 1e-4).sum(); }

}  // namespace fskin
