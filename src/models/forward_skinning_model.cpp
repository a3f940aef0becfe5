#include "fskin/training/articulated_occupancy_model.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/deformers/snarf_deformer.h"
#include "fskin/invertible/fused_pin_pass.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/training/bootstrap_losses.h"
#include "fskin/training/occupancy_aggregation.h"
#include "fskin/util/stopwatch.h"

namespace fskin {

ArticulatedOccupancyModel::ArticulatedOccupancyModel(const ArticulatedModelOptions& options)
    : options_(options) {
  FSKIN_CHECK(options.method == Method::FastSnarf || options.method == Method::Snarf || options.method == Method::Ins,
              "ArticulatedOccupancyModel: method {} is not a forward-skinning method", method_name(options.method));
  occupancy_ = register_module("occupancy", OccupancyNetwork(options.occupancy));
  skinning_ = register_module("skinning", std::make_shared<MlpSkinningField>(options.skinning));
  if (options.method == Method::Snarf) {
    deformer_ = std::make_unique<SnarfDeformer>(skinning_, options.deformer);
  } else {
    options.box.validate("model: skinning grid box");
    deformer_ = std::make_unique<FastSnarfDeformer>(std::make_shared<DistilledSkinningField>(skinning_, options.box),
                                                    options.deformer);
  }
  if (invertible()) {
    FSKIN_CHECK(options.occupancy.pose_dim == 0, "ins: the canonical shape must be pose-free (pose_dim = 0)");
    auto pin = options.pin;
    pin.own_pose_encoder = false;  // one encoder drives both PINs (Table 4)
    pose_encoder_ = register_module("pose_encoder", PoseEncoder(options.pin.pose));
    pin_canonical_ = register_module("pin_canonical", Pin(pin));
    pin_deformed_ = register_module("pin_deformed", Pin(pin));
  }
}

torch::Tensor ArticulatedOccupancyModel::through_pin(Pin& pin, const torch::Tensor& x,
                                                     const torch::Tensor& pose_embedding, bool inverse) {
  const auto& frame = options_.occupancy.input;
  const auto u = frame.apply(x);
  // Inference (evaluation, meshing, re-posing) takes the fused kernel: the same
  // function to float32 rounding, ~30x faster per PIN pass (docs/ins.md, "Speed").
  if (!torch::GradMode::is_enabled() && u.scalar_type() == torch::kFloat32 && fused_pin_pass_supports(*pin)) {
    return frame.unapply(fused_pin_pass(*pin, u, pose_embedding, inverse));
  }
  return frame.unapply(inverse ? pin->inverse_embedded(u, pose_embedding) : pin->forward_embedded(u, pose_embedding));
}

OccupancyPrediction ArticulatedOccupancyModel::predict(const torch::Tensor& points, const torch::Tensor& bones,
                                                       const torch::Tensor& pose, Aggregation aggregation) {
  OccupancyPrediction out;
  Stopwatch watch(points.is_cuda());
  torch::Tensor pose_embedding, query = points;
  if (invertible()) {
    pose_embedding = pose_encoder_->forward(bones.to(points.dtype()));
    query = through_pin(pin_deformed_, points, pose_embedding, false);
  }
  auto found = deformer().forward(query, bones);
  out.deformer = found.stats;
  out.deformer_seconds = watch.lap();

  // The shape network runs only on valid candidates (typically ~1 of the I
  // slots); invalid slots keep a placeholder the aggregation masks out.
  const int64_t B = points.size(0), slots = points.size(1) * found.valid.size(2);
  std::vector<torch::Tensor> indices, values;
  for (int64_t b = 0; b < B; ++b) {
    const auto selected = found.valid[b].flatten().nonzero().squeeze(1);
    if (selected.numel() == 0) continue;
    auto x = found.x_canonical[b].reshape({-1, 3}).index_select(0, selected).unsqueeze(0);
    if (invertible()) x = through_pin(pin_canonical_, x, pose_embedding.slice(0, b, b + 1), false);
    values.push_back(canonical_logits(x, pose.slice(0, b, b + 1)).squeeze(0));
    indices.push_back(selected + b * slots);
  }
  auto logits = torch::full({B * slots}, -kMaxOccupancyLogit, points.options());
  if (!values.empty()) logits = logits.index_put({torch::cat(indices)}, torch::cat(values));
  logits = logits.view({B, points.size(1), found.valid.size(2)});
  out.shape_seconds = watch.lap();

  out.logits = aggregation == Aggregation::Soft ? soft_max_occupancy(logits, found.valid)
                                                : hard_max_occupancy(logits, found.valid);
  out.aggregation_seconds = watch.lap();
  return out;
}

torch::Tensor ArticulatedOccupancyModel::canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) {
  if (options_.occupancy.pose_dim == 0) return occupancy_->forward(x_canonical);
  return occupancy_->forward(x_canonical, pose_condition(pose).to(x_canonical.dtype()));
}

torch::Tensor ArticulatedOccupancyModel::bootstrap_loss(const BootstrapInputs& inputs) {
  FSKIN_CHECK(inputs.skeleton != nullptr, "bootstrap_loss: no skeleton");
  return bone_occupancy_loss(*this, inputs.bone_points, inputs.pose) +
         inputs.joint_weight * joint_weight_loss(deformer().field(), *inputs.skeleton);
}

torch::Tensor ArticulatedOccupancyModel::skinning_weights(const torch::Tensor& x_canonical) {
  return deformer().field().weights(x_canonical);
}

torch::Tensor ArticulatedOccupancyModel::repose(const torch::Tensor& x_canonical, const torch::Tensor& bones) {
  expect_shape(x_canonical, {-1, -1, 3}, "repose: canonical points");
  expect_shape(bones, {x_canonical.size(0), options_.skinning.num_bones, 4, 4}, "repose: bones");
  if (!invertible()) return deformer().deform(x_canonical, bones);
  const auto pose_embedding = pose_encoder_->forward(bones.to(x_canonical.dtype()));
  const auto lbs_canonical = through_pin(pin_canonical_, x_canonical, pose_embedding, true);
  return through_pin(pin_deformed_, deformer().deform(lbs_canonical, bones), pose_embedding, true);
}

std::vector<OccupancyModel::ParameterGroup> ArticulatedOccupancyModel::parameter_groups(double learning_rate) {
  std::vector<torch::Tensor> pins, skinning = skinning_->parameters(), rest = occupancy_->parameters();
  if (invertible()) {
    for (const auto& list : {pose_encoder_->parameters(), pin_canonical_->parameters(), pin_deformed_->parameters()}) {
      pins.insert(pins.end(), list.begin(), list.end());
    }
  }
  FSKIN_CHECK(pins.size() + skinning.size() + rest.size() == parameters().size(),
              "{}: parameter groups miss {} parameters", method_name(options_.method),
              parameters().size() - pins.size() - skinning.size() - rest.size());
  std::vector<ParameterGroup> groups{{rest, learning_rate},
                                     {skinning, learning_rate * options_.skinning_learning_rate_factor}};
  if (invertible()) groups.push_back({pins, learning_rate * options_.pin_learning_rate_factor});
  return groups;
}

void ArticulatedOccupancyModel::freeze_for_inference() {
  if (options_.method == Method::Snarf || frozen_deformer_) return;
  torch::NoGradGuard no_grad;
  auto& distilled = static_cast<DistilledSkinningField&>(deformer_->field());
  frozen_deformer_ = std::make_unique<FastSnarfDeformer>(distilled.freeze(), deformer_->options());
}

void ArticulatedOccupancyModel::train(bool on) {
  torch::nn::Module::train(on);
  if (on) frozen_deformer_.reset();
}

}  // namespace fskin
