#include "fskin/gaussians/opacity_prior.h"

namespace fskin {

torch::Tensor opacity_entropy(const GaussianAvatarImpl& avatar) {
  const auto o = torch::sigmoid(avatar.opacity_logits()).clamp(1e-6, 1 - 1e-6);
  return -(o * o.log() + (1 - o) * (1 - o).log()).mean();
}

}  // namespace fskin
