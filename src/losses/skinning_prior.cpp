#include "fskin/losses/skinning_prior.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

torch::Tensor nearest_bone_weights(const CanonicalSkeleton& skeleton, const torch::Tensor& points) {
  expect_shape(points, {-1, 3}, "skinning prior: points");
  const int64_t J = static_cast<int64_t>(skeleton.parents.size());
  FSKIN_CHECK(J >= 2, "skinning prior: the skeleton needs >= 2 joints, has {}", J);
  std::vector<int64_t> heads, tails;
  for (int64_t j = 1; j < J; ++j) {
    heads.push_back(skeleton.parents[j]);
    tails.push_back(j);
  }
  const auto joints = skeleton.joints.to(points.dtype());
  const auto a = joints.index_select(0, torch::tensor(heads)), b = joints.index_select(0, torch::tensor(tails));
  const auto ab = b - a;                                               // [S, 3]
  const auto ap = points.unsqueeze(1) - a.unsqueeze(0);                // [M, S, 3]
  const auto t = ((ap * ab).sum(-1) / ab.square().sum(-1).clamp_min(1e-12)).clamp(0.0, 1.0);  // [M, S]
  const auto distance = (ap - t.unsqueeze(-1) * ab).norm(2, -1);      // [M, S]
  const auto nearest = distance.argmin(1);                             // segment index
  const auto bone = torch::tensor(heads).index_select(0, nearest);    // its head joint's bone
  return torch::one_hot(bone, J).to(points.dtype());
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
