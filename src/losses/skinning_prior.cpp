#include "fskin/losses/skinning_prior.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

torch::Tensor nearest_bone_weights(const CanonicalSkeleton& skeleton, const torch::Tensor& points) {
  return torch::one_hot(nearest_bone(skeleton, points), static_cast<int64_t>(skeleton.parents.size()))
      .to(points.dtype());
}

torch::Tensor skinning_prior_points(const CanonicalSkeleton& skeleton, int64_t count, uint64_t seed) {
  FSKIN_CHECK(count >= 2, "skinning prior: need >= 2 points, got {}", count);
  auto generator = at::make_generator<at::CPUGeneratorImpl>(seed);
  const auto extent = skeleton.extent.to(torch::kFloat32);
  const auto lo = std::get<0>(extent.min(0)), hi = std::get<0>(extent.max(0));
  const auto centre = (lo + hi) / 2, half = (hi - lo) / 2 * 1.2;
  const int64_t from_extent = std::min<int64_t>(count / 2, extent.size(0));
  const auto picks = torch::randperm(extent.size(0), generator).slice(0, 0, from_extent);
  const auto box = centre - half + torch::rand({count - from_extent, 3}, generator) * 2 * half;
  return torch::cat({extent.index_select(0, picks), box});
}

double fit_skinning_prior(SkinningField& field, const CanonicalSkeleton& skeleton, int64_t steps,
                          double learning_rate, uint64_t seed) {
  FSKIN_CHECK(steps >= 0 && learning_rate > 0, "skinning prior: steps {} and learning rate {} out of range", steps,
              learning_rate);
  const auto host_points = skinning_prior_points(skeleton, 2048, seed);
  const auto device = module_device(field);
  const auto points = host_points.to(device);
  const auto target = nearest_bone_weights(skeleton, host_points).to(device);
  torch::optim::Adam adam(field.parameters(), torch::optim::AdamOptions(learning_rate));
  double loss_value = 0;
  for (int64_t step = 0; step < steps; ++step) {
    const auto w = field.weights(points);
    const auto loss = -(target * torch::log(w.clamp_min(1e-6))).sum(-1).mean();
    adam.zero_grad();
    loss.backward();
    adam.step();
    loss_value = loss.item<double>();
  }
  return loss_value;
}

}  // namespace fskin
