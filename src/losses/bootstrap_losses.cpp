#include "fskin/losses/bootstrap_losses.h"

#include <torch/torch.h>

#include "fskin/core/device.h"
#include "fskin/core/error.h"

namespace fskin {

torch::Tensor sample_bone_points(const CanonicalSkeleton& skeleton, int64_t per_bone, at::Generator& generator) {
  FSKIN_CHECK(per_bone >= 1, "bootstrap: points per bone must be >= 1, got {}", per_bone);
  std::vector<int64_t> heads, tails;
  for (int64_t j = 1; j < static_cast<int64_t>(skeleton.parents.size()); ++j) {
    if (!skeleton.counts_segment(j)) continue;
    heads.push_back(skeleton.parents[j]);
    tails.push_back(j);
  }
  FSKIN_CHECK(!heads.empty(), "bootstrap: the skeleton has no bones in the body (one joint, or every segment outside)");
  const auto joints = skeleton.joints.to(torch::kFloat32);
  const auto head = joints.index_select(0, torch::tensor(heads)).unsqueeze(1);  // [S, 1, 3]
  const auto tail = joints.index_select(0, torch::tensor(tails)).unsqueeze(1);
  const auto base = torch::linspace(0.0, 1.0, per_bone).view({1, per_bone, 1});
  const auto noise = torch::randn({static_cast<int64_t>(heads.size()), per_bone, 1}, generator) * 0.1;
  const auto t = (base + noise).clamp(0.0, 1.0);
  return (head + t * (tail - head)).view({-1, 3});
}

torch::Tensor bone_occupancy_loss(OccupancyModel& model, const torch::Tensor& bone_points,
                                  const torch::Tensor& pose) {
  const auto x = bone_points.to(pose.device()).unsqueeze(0).expand({pose.size(0), bone_points.size(0), 3});
  const auto logits = model.canonical_logits(x, pose);
  return torch::binary_cross_entropy_with_logits(logits, torch::ones_like(logits));
}

torch::Tensor joint_weight_loss(SkinningField& field, const CanonicalSkeleton& skeleton) {
  // Joints none of whose segments lie in the body (a root on the ground
  // below the hips) drive no skin: their one-hot weight there would be wrong.
  const int64_t J = static_cast<int64_t>(skeleton.parents.size());
  std::vector<bool> in_body(J, skeleton.segment_in_body.empty());
  for (int64_t j = 1; j < J && !skeleton.segment_in_body.empty(); ++j)
    if (skeleton.counts_segment(j)) in_body[j] = in_body[skeleton.parents[j]] = true;
  std::vector<int64_t> kept;
  for (int64_t j = 0; j < J; ++j)
    if (in_body[j] || J < 2) kept.push_back(j);
  if (kept.empty())
    for (int64_t j = 0; j < J; ++j) kept.push_back(j);
  const auto index = torch::tensor(kept);
  const auto joints = skeleton.joints.index_select(0, index).to(module_device(field), torch::kFloat32);
  const auto weights = field.weights(joints);  // [K, J]
  const auto target = torch::eye(J, joints.options()).index_select(0, index.to(joints.device()));
  return torch::mse_loss(weights, target);
}

torch::Tensor bootstrap_loss(OccupancyModel& model, const BootstrapInputs& inputs) {
  FSKIN_CHECK(inputs.skeleton != nullptr, "bootstrap_loss: no skeleton");
  if (!model.has_canonical_shape()) return {};
  auto loss = bone_occupancy_loss(model, inputs.bone_points, inputs.pose);
  if (auto* field = model.deformer_skinning_field()) {
    loss = loss + inputs.joint_weight * joint_weight_loss(*field, *inputs.skeleton);
  }
  return loss;
}

}  // namespace fskin
