#pragma once
// SNARF and Fast-SNARF: a canonical occupancy network plus a learned skinning
// field, joined by a forward-skinning deformer. A posed point's occupancy is
// the aggregate over its canonical correspondences (SNARF eq. 9). SNARF's
// deformer queries the skinning MLP at every Broyden step; Fast-SNARF's
// queries a voxel grid distilled from it every step (Fast-SNARF sec. 4.2).
// INS (ins_model.h) wraps this model's search in invertible networks.
#include <torch/torch.h>

#include <memory>

#include "fskin/canonical/occupancy_network.h"
#include "fskin/deformers/deformer.h"
#include "fskin/fields/mlp_skinning_field.h"
#include "fskin/geometry/voxel_box.h"
#include "fskin/models/method.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

struct ForwardSkinningModelOptions {
  // Snarf: the deformer queries the skinning MLP; FastSnarf (and INS): a grid
  // distilled from it over `box`.
  Method method = Method::FastSnarf;
  OccupancyNetworkOptions occupancy;  // pose_dim > 0 enables pose conditioning
  MlpSkinningFieldOptions skinning;
  VoxelBox box;  // Fast-SNARF's skinning grid (and its validity region)
  DeformerOptions deformer = DeformerOptions::fast_snarf();
  // The skinning network's learning rate relative to the rest (papers: 1).
  double skinning_learning_rate_factor = 1.0;
};

class ForwardSkinningModel : public OccupancyModel {
 public:
  explicit ForwardSkinningModel(const ForwardSkinningModelOptions& options);

  OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones, const torch::Tensor& pose,
                              Aggregation aggregation) override;
  bool has_canonical_shape() const override { return true; }
  torch::Tensor canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) override;
  SkinningField* canonical_skinning_field() override { return skinning_.get(); }
  SkinningField* deformer_skinning_field() override { return &deformer().field(); }
  void set_frequency_window(double window) override { occupancy_->set_frequency_window(window); }
  // Skinning weights the deformer uses at canonical points [..., 3] -> [..., J].
  torch::Tensor skinning_weights(const torch::Tensor& x_canonical);

  // Canonical points [B, V, 3] -> posed [B, V, 3] for bones [B, J, 4, 4] by
  // LBS with the learned weights: exact vertex correspondences across poses;
  // for pose-conditioned SNARF it ignores the pose-dependent shape (mesh each
  // pose instead).
  torch::Tensor repose(const torch::Tensor& x_canonical, const torch::Tensor& bones) override;
  std::vector<ParameterGroup> parameter_groups(double learning_rate) override;

  // Fast-SNARF: fix the distilled grid (no MLP pass per query) until the next
  // train(true). A no-op for SNARF.
  void freeze_for_inference() override;
  void train(bool on = true) override;

  const ForwardSkinningModelOptions& options() const { return options_; }
  Deformer& deformer() { return frozen_deformer_ ? *frozen_deformer_ : *deformer_; }

 protected:
  // Hooks around the search for models that transform space before and after
  // it (INS). `pose_features` is what encode_pose returned for the batch.
  virtual torch::Tensor encode_pose(const torch::Tensor& bones, torch::ScalarType dtype) { return {}; }
  // Posed query points [B, N, 3] -> the deformer's posed space.
  virtual torch::Tensor to_search_space(const torch::Tensor& points, const torch::Tensor& pose_features) {
    return points;
  }
  // Roots [1, M, 3] of frame b -> the occupancy network's canonical space.
  virtual torch::Tensor to_shape_space(const torch::Tensor& roots, const torch::Tensor& pose_features, int64_t b) {
    return roots;
  }

 private:
  ForwardSkinningModelOptions options_;
  OccupancyNetwork occupancy_{nullptr};
  std::shared_ptr<MlpSkinningField> skinning_;
  std::unique_ptr<Deformer> deformer_, frozen_deformer_;
};

}  // namespace fskin
