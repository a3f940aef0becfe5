#include "fskin/gaussians/surface_layer.h"

namespace fskin {

torch::Tensor surface_layer_spread(const GaussianAvatarImpl& avatar) {
  const auto heights = avatar.anchor_heights() / avatar.initial_spacing();
  return (heights - heights.mean().detach()).square().mean();
}

}  // namespace fskin
