#include "fskin/models/ins_model.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/ops/pin_pass.h"

namespace fskin {

namespace {
const ForwardSkinningModelOptions& checked_lbs(const InsModelOptions& options) {
  FSKIN_CHECK(options.lbs.method == Method::FastSnarf, "ins: the LBS search must be Fast-SNARF's");
  FSKIN_CHECK(options.lbs.occupancy.pose_dim == 0, "ins: the canonical shape must be pose-free (pose_dim = 0)");
  return options.lbs;
}
}  // namespace

InsModel::InsModel(const InsModelOptions& options) : ForwardSkinningModel(checked_lbs(options)), ins_options_(options) {
  auto pin = options.pin;
  pin.own_pose_encoder = false;  // one encoder drives both PINs (Table 4)
  pose_encoder_ = register_module("pose_encoder", PoseEncoder(options.pin.pose));
  pin_canonical_ = register_module("pin_canonical", Pin(pin));
  pin_deformed_ = register_module("pin_deformed", Pin(pin));
}

torch::Tensor InsModel::through_pin(Pin& pin, const torch::Tensor& x, const torch::Tensor& pose_embedding,
                                    bool inverse) {
  const auto& frame = options().occupancy.input;
  const auto u = frame.apply(x);
  // Inference (evaluation, meshing, re-posing) takes the fused kernel: the same
  // function to float32 rounding, faster per PIN pass (docs/ins.md, "Speed").
  if (!torch::GradMode::is_enabled() && u.scalar_type() == torch::kFloat32 && fused_pin_pass_supports(*pin)) {
    return frame.unapply(fused_pin_pass(*pin, u, pose_embedding, inverse));
  }
  return frame.unapply(inverse ? pin->inverse_embedded(u, pose_embedding) : pin->forward_embedded(u, pose_embedding));
}

torch::Tensor InsModel::encode_pose(const torch::Tensor& bones, torch::ScalarType dtype) {
  return pose_encoder_->forward(bones.to(dtype));
}

torch::Tensor InsModel::to_search_space(const torch::Tensor& points, const torch::Tensor& pose_embedding) {
  return through_pin(pin_deformed_, points, pose_embedding, false);
}

torch::Tensor InsModel::to_shape_space(const torch::Tensor& roots, const torch::Tensor& pose_embedding, int64_t b) {
  return through_pin(pin_canonical_, roots, pose_embedding.slice(0, b, b + 1), false);
}

torch::Tensor InsModel::repose(const torch::Tensor& x_canonical, const torch::Tensor& bones) {
  expect_shape(x_canonical, {-1, -1, 3}, "repose: canonical points");
  expect_shape(bones, {x_canonical.size(0), options().skinning.num_bones, 4, 4}, "repose: bones");
  const auto pose_embedding = encode_pose(bones, x_canonical.scalar_type());
  const auto lbs_canonical = through_pin(pin_canonical_, x_canonical, pose_embedding, true);
  return through_pin(pin_deformed_, deformer().deform(lbs_canonical, bones), pose_embedding, true);
}

std::vector<OccupancyModel::ParameterGroup> InsModel::parameter_groups(double learning_rate) {
  auto groups = ForwardSkinningModel::parameter_groups(learning_rate);
  std::vector<torch::Tensor> pins;
  for (const auto& list : {pose_encoder_->parameters(), pin_canonical_->parameters(), pin_deformed_->parameters()}) {
    pins.insert(pins.end(), list.begin(), list.end());
  }
  groups.push_back({pins, learning_rate * ins_options_.pin_learning_rate_factor});
  return groups;
}

}  // namespace fskin
