#pragma once
// The papers' articulated model: a canonical occupancy network plus a learned
// skinning field, joined by a forward-skinning deformer. A posed point's
// occupancy is the aggregate over its canonical correspondences (SNARF eq. 9).
#include <torch/torch.h>

#include <memory>
#include <string>

#include "fskin/canonical/occupancy_network.h"
#include "fskin/deformers/deformer.h"
#include "fskin/fields/mlp_skinning_field.h"
#include "fskin/fields/voxel_box.h"
#include "fskin/training/method.h"
#include "fskin/training/occupancy_model.h"

namespace fskin {

struct ArticulatedModelOptions {
  Method method = Method::FastSnarf;  // FastSnarf or Snarf
  OccupancyNetworkOptions occupancy;  // pose_dim > 0 enables pose conditioning
  MlpSkinningFieldOptions skinning;
  VoxelBox box;  // Fast-SNARF's skinning grid (and its validity region)
  DeformerOptions deformer = DeformerOptions::fast_snarf();
};

class ArticulatedOccupancyModel : public OccupancyModel {
 public:
  explicit ArticulatedOccupancyModel(const ArticulatedModelOptions& options);

  OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones, const torch::Tensor& pose,
                              Aggregation aggregation) override;
  // Bone occupancy + joint skinning weights (SNARF sec. 3.3).
  torch::Tensor bootstrap_loss(const BootstrapInputs& inputs) override;
  bool has_canonical_shape() const override { return true; }
  torch::Tensor canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) override;
  SkinningField* canonical_skinning_field() override { return skinning_.get(); }
  // Skinning weights the deformer uses at canonical points [..., 3] -> [..., J].
  torch::Tensor skinning_weights(const torch::Tensor& x_canonical);

  // Fast-SNARF: fix the distilled grid (no MLP pass per query) until the next
  // train(true). A no-op for SNARF.
  void freeze_for_inference() override;
  void train(bool on = true) override;

  const ArticulatedModelOptions& options() const { return options_; }
  Deformer& deformer() { return frozen_deformer_ ? *frozen_deformer_ : *deformer_; }

 private:
  ArticulatedModelOptions options_;
  OccupancyNetwork occupancy_{nullptr};
  std::shared_ptr<MlpSkinningField> skinning_;
  std::unique_ptr<Deformer> deformer_, frozen_deformer_;
};

}  // namespace fskin
