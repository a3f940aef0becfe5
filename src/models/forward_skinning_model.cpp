#include "fskin/models/forward_skinning_model.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/deformers/snarf_deformer.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/models/occupancy_aggregation.h"
#include "fskin/models/pose_condition.h"
#include "fskin/util/stopwatch.h"

namespace fskin {

ForwardSkinningModel::ForwardSkinningModel(const ForwardSkinningModelOptions& options) : options_(options) {
  FSKIN_CHECK(options.method == Method::FastSnarf || options.method == Method::Snarf,
              "ForwardSkinningModel: the method must be snarf or fast-snarf");
  occupancy_ = register_module("occupancy", OccupancyNetwork(options.occupancy));
  skinning_ = register_module("skinning", std::make_shared<MlpSkinningField>(options.skinning));
  if (options.method == Method::Snarf) {
    deformer_ = std::make_unique<SnarfDeformer>(skinning_, options.deformer);
  } else {
    options.box.validate("model: skinning grid box");
    deformer_ = std::make_unique<FastSnarfDeformer>(std::make_shared<DistilledSkinningField>(skinning_, options.box),
                                                    options.deformer);
  }
}

OccupancyPrediction ForwardSkinningModel::predict(const torch::Tensor& points, const torch::Tensor& bones,
                                                  const torch::Tensor& pose, Aggregation aggregation) {
  OccupancyPrediction out;
  Stopwatch watch(points.is_cuda());
  const auto pose_features = encode_pose(bones, points.scalar_type());
  auto found = deformer().forward(to_search_space(points, pose_features), bones);
  out.deformer = found.stats;
  out.deformer_seconds = watch.lap();

  // The shape network runs only on valid candidates (typically ~1 of the I
  // slots); invalid slots keep a placeholder the aggregation masks out.
  const int64_t B = points.size(0), slots = points.size(1) * found.valid.size(2);
  std::vector<torch::Tensor> indices, values;
  for (int64_t b = 0; b < B; ++b) {
    const auto selected = found.valid[b].flatten().nonzero().squeeze(1);
    if (selected.numel() == 0) continue;
    const auto roots = found.x_canonical[b].reshape({-1, 3}).index_select(0, selected).unsqueeze(0);
    values.push_back(canonical_logits(to_shape_space(roots, pose_features, b), pose.slice(0, b, b + 1)).squeeze(0));
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

torch::Tensor ForwardSkinningModel::canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) {
  if (options_.occupancy.pose_dim == 0) return occupancy_->forward(x_canonical);
  return occupancy_->forward(x_canonical, pose_condition(pose).to(x_canonical.dtype()));
}

torch::Tensor ForwardSkinningModel::skinning_weights(const torch::Tensor& x_canonical) {
  return deformer().field().weights(x_canonical);
}

torch::Tensor ForwardSkinningModel::repose(const torch::Tensor& x_canonical, const torch::Tensor& bones) {
  expect_shape(x_canonical, {-1, -1, 3}, "repose: canonical points");
  expect_shape(bones, {x_canonical.size(0), options_.skinning.num_bones, 4, 4}, "repose: bones");
  return deformer().deform(x_canonical, bones);
}

std::vector<OccupancyModel::ParameterGroup> ForwardSkinningModel::parameter_groups(double learning_rate) {
  return {{occupancy_->parameters(), learning_rate},
          {skinning_->parameters(), learning_rate * options_.skinning_learning_rate_factor}};
}

void ForwardSkinningModel::freeze_for_inference() {
  if (options_.method == Method::Snarf || frozen_deformer_) return;
  torch::NoGradGuard no_grad;
  auto& distilled = static_cast<DistilledSkinningField&>(deformer_->field());
  frozen_deformer_ = std::make_unique<FastSnarfDeformer>(distilled.freeze(), deformer_->options());
}

void ForwardSkinningModel::train(bool on) {
  torch::nn::Module::train(on);
  if (on) frozen_deformer_.reset();
}

}  // namespace fskin
