#include "fskin/invertible/pin.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

std::vector<std::vector<int64_t>> pin_split_schedule(int64_t num_layers) {
  static const std::vector<std::vector<int64_t>> cycle = {{0, 1}, {2}, {1, 2}, {0}, {2, 0}, {1}};
  std::vector<std::vector<int64_t>> schedule;
  for (int64_t k = 0; k < num_layers; ++k) schedule.push_back(cycle[k % cycle.size()]);
  return schedule;
}

void PinOptions::validate() const {
  FSKIN_CHECK(num_layers >= 1, "PinOptions: num_layers must be >= 1, got {}", num_layers);
  coupling.validate();
  if (own_pose_encoder) {
    pose.validate();
    FSKIN_CHECK(pose.embedding_dim() == coupling.embedding_dim,
                "PinOptions: pose embedding width {} (num_bones {} x per_bone_dim {}) must equal "
                "coupling.embedding_dim {} (the Hadamard product of eq. 9)",
                pose.embedding_dim(), pose.num_bones, pose.per_bone_dim, coupling.embedding_dim);
  }
}

PinImpl::PinImpl(const PinOptions& o) : options_(o) {
  o.validate();
  if (o.own_pose_encoder) pose_encoder_ = register_module("pose_encoder", PoseEncoder(o.pose));
  const auto schedule = pin_split_schedule(o.num_layers);
  for (size_t k = 0; k < schedule.size(); ++k) {
    const auto& moved = schedule[k];
    std::shared_ptr<CouplingLayer> layer;
    if (moved.size() == 2) {
      layer = std::make_shared<CouplingLayer2D>(moved[0], moved[1], o.coupling);
    } else {
      layer = std::make_shared<CouplingLayer1D>(moved[0], o.coupling);
    }
    layers_.push_back(register_module("layer" + std::to_string(k), layer));
  }
}

torch::Tensor PinImpl::encode_pose(const torch::Tensor& bones) {
  FSKIN_CHECK(!pose_encoder_.is_empty(),
              "PIN: this PIN has no pose encoder (own_pose_encoder = false); pass pose embeddings "
              "to forward_embedded / inverse_embedded");
  return pose_encoder_->forward(bones);
}

void PinImpl::check_frames(const torch::Tensor& points, const torch::Tensor& bones) const {
  expect_shape(points, {-1, -1, 3}, "PIN: points");
  expect_shape(bones, {-1, -1, 4, 4}, "PIN: bones");
  FSKIN_CHECK(points.size(0) == bones.size(0), "PIN: points have {} frames but bones have {}", points.size(0),
              bones.size(0));
}

void PinImpl::check_inputs(const torch::Tensor& points, const torch::Tensor& pose_embedding) const {
  expect_shape(points, {-1, -1, 3}, "PIN: points");
  expect_floating(points, "PIN: points");
  expect_finite(points, "PIN: points");
  expect_shape(pose_embedding, {points.size(0), options_.coupling.embedding_dim}, "PIN: pose embedding");
  expect_finite(pose_embedding, "PIN: pose embedding");
}

torch::Tensor PinImpl::forward(const torch::Tensor& x, const torch::Tensor& bones) {
  check_frames(x, bones);
  return forward_embedded(x, encode_pose(bones));
}

torch::Tensor PinImpl::inverse(const torch::Tensor& y, const torch::Tensor& bones) {
  check_frames(y, bones);
  return inverse_embedded(y, encode_pose(bones));
}

torch::Tensor PinImpl::forward_embedded(const torch::Tensor& x, const torch::Tensor& pose_embedding) {
  check_inputs(x, pose_embedding);
  torch::Tensor h = x;
  for (auto& layer : layers_) h = layer->forward(h, pose_embedding);  // eq. 13
  return h;
}

torch::Tensor PinImpl::inverse_embedded(const torch::Tensor& y, const torch::Tensor& pose_embedding) {
  check_inputs(y, pose_embedding);
  torch::Tensor h = y;
  for (auto it = layers_.rbegin(); it != layers_.rend(); ++it) h = (*it)->inverse(h, pose_embedding);  // eq. 14
  return h;
}

}  // namespace fskin
