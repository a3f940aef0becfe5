#include "fskin/gaussians/opacity_prior.h"

#include "fskin/gaussians/binary_entropy.h"

namespace fskin {

torch::Tensor opacity_entropy(const GaussianAvatarImpl& avatar) {
  return binary_entropy(torch::sigmoid(avatar.opacity_logits()), 1e-6).mean();
}

}  // namespace fskin
