#include "fskin/training/articulated_occupancy_model.h"

#include <chrono>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/deformers/snarf_deformer.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/training/occupancy_aggregation.h"

namespace fskin {

Method parse_method(const std::string& name) {
  if (name == "fast-snarf") return Method::FastSnarf;
  if (name == "snarf") return Method::Snarf;
  fail("unknown method '{}' (expected fast-snarf or snarf)", name);
}

std::string method_name(Method method) { return method == Method::FastSnarf ? "fast-snarf" : "snarf"; }

torch::Tensor pose_condition(const torch::Tensor& pose) {
  expect_shape(pose, {-1, -1, 3}, "pose_condition: pose");
  return pose.slice(1, 1).flatten(1) / M_PI;
}

ArticulatedOccupancyModel::ArticulatedOccupancyModel(const ArticulatedModelOptions& options)
    : options_(options) {
  occupancy_ = register_module("occupancy", OccupancyNetwork(options.occupancy));
  skinning_ = register_module("skinning", std::make_shared<MlpSkinningField>(options.skinning));
  if (options.method == Method::FastSnarf) {
    options.box.validate("model: skinning grid box");
    deformer_ = std::make_unique<FastSnarfDeformer>(std::make_shared<DistilledSkinningField>(skinning_, options.box),
                                                    options.deformer);
  } else {
    deformer_ = std::make_unique<SnarfDeformer>(skinning_, options.deformer);
  }
}

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}
}  // namespace

OccupancyPrediction ArticulatedOccupancyModel::predict(const torch::Tensor& points, const torch::Tensor& bones,
                                                       const torch::Tensor& pose, Aggregation aggregation) {
  OccupancyPrediction out;
  auto start = Clock::now();
  auto found = deformer().forward(points, bones);
  out.deformer = found.stats;
  out.deformer_seconds = seconds_since(start);

  start = Clock::now();
  // The shape network runs only on valid candidates (typically ~1 of the I
  // slots); invalid slots keep a placeholder the aggregation masks out.
  const int64_t B = points.size(0), slots = points.size(1) * found.valid.size(2);
  std::vector<torch::Tensor> indices, values;
  for (int64_t b = 0; b < B; ++b) {
    const auto selected = found.valid[b].flatten().nonzero().squeeze(1);
    if (selected.numel() == 0) continue;
    const auto x = found.x_canonical[b].reshape({-1, 3}).index_select(0, selected).unsqueeze(0);
    values.push_back(canonical_logits(x, pose.slice(0, b, b + 1)).squeeze(0));
    indices.push_back(selected + b * slots);
  }
  auto logits = torch::full({B * slots}, -kMaxOccupancyLogit, points.options());
  if (!values.empty()) logits = logits.index_put({torch::cat(indices)}, torch::cat(values));
  logits = logits.view({B, points.size(1), found.valid.size(2)});
  out.shape_seconds = seconds_since(start);

  start = Clock::now();
  out.logits = aggregation == Aggregation::Soft ? soft_max_occupancy(logits, found.valid)
                                                : hard_max_occupancy(logits, found.valid);
  out.aggregation_seconds = seconds_since(start);
  return out;
}

torch::Tensor ArticulatedOccupancyModel::canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) {
  if (options_.occupancy.pose_dim == 0) return occupancy_->forward(x_canonical);
  return occupancy_->forward(x_canonical, pose_condition(pose).to(x_canonical.dtype()));
}

torch::Tensor ArticulatedOccupancyModel::skinning_weights(const torch::Tensor& x_canonical) {
  return deformer().field().weights(x_canonical);
}

void ArticulatedOccupancyModel::freeze_for_inference() {
  if (options_.method != Method::FastSnarf || frozen_deformer_) return;
  torch::NoGradGuard no_grad;
  auto& distilled = static_cast<DistilledSkinningField&>(deformer_->field());
  frozen_deformer_ = std::make_unique<FastSnarfDeformer>(distilled.freeze(), deformer_->options());
}

void ArticulatedOccupancyModel::train(bool on) {
  torch::nn::Module::train(on);
  if (on) frozen_deformer_.reset();
}

}  // namespace fskin
