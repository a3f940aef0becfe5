#pragma once
// The papers' articulated model: a canonical occupancy network plus a learned
// skinning field, joined by a forward-skinning deformer. A posed point's
// occupancy is the aggregate over its canonical correspondences (SNARF eq. 9).
//
// With method Ins, two pose-conditioned invertible networks sit around the
// differentiable LBS (INS sec. 3.3, eq. 16): a posed point x' goes through
// PIN_d, the Broyden search finds its LBS roots, PIN_c maps them to the
// pose-free canonical space. Re-posing (eq. 19) runs the chain backwards on
// canonical points: PIN_c^-1, forward LBS, PIN_d^-1.
#include <torch/torch.h>

#include <memory>
#include <string>

#include "fskin/canonical/occupancy_network.h"
#include "fskin/deformers/deformer.h"
#include "fskin/fields/mlp_skinning_field.h"
#include "fskin/fields/voxel_box.h"
#include "fskin/invertible/pin.h"
#include "fskin/invertible/pose_encoding.h"
#include "fskin/training/method.h"
#include "fskin/training/occupancy_model.h"

namespace fskin {

struct ArticulatedModelOptions {
  Method method = Method::FastSnarf;  // FastSnarf, Snarf or Ins (Fast-SNARF's search inside)
  OccupancyNetworkOptions occupancy;  // pose_dim > 0 enables pose conditioning
  MlpSkinningFieldOptions skinning;
  VoxelBox box;  // Fast-SNARF's skinning grid (and its validity region)
  DeformerOptions deformer = DeformerOptions::fast_snarf();
  // Ins: the two PINs (sharing one pose encoder, pin.pose) and their learning
  // rate relative to the rest (paper: 1e-4 vs 1e-3).
  PinOptions pin;
  double pin_learning_rate_factor = 0.1;
  // The skinning network's learning rate relative to the rest (papers: 1).
  double skinning_learning_rate_factor = 1.0;
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

  // Canonical points [B, V, 3] -> posed [B, V, 3] for bones [B, J, 4, 4]: LBS
  // with the learned weights, wrapped in PIN_c^-1 / PIN_d^-1 for Ins (eq. 19).
  // Exact vertex correspondences across poses; for pose-conditioned SNARF it
  // ignores the pose-dependent shape (mesh each pose instead).
  torch::Tensor repose(const torch::Tensor& x_canonical, const torch::Tensor& bones) override;
  bool invertible() const { return options_.method == Method::Ins; }
  std::vector<ParameterGroup> parameter_groups(double learning_rate) override;

  // Fast-SNARF / Ins: fix the distilled grid (no MLP pass per query) until the
  // next train(true). A no-op for SNARF.
  void freeze_for_inference() override;
  void train(bool on = true) override;

  const ArticulatedModelOptions& options() const { return options_; }
  Deformer& deformer() { return frozen_deformer_ ? *frozen_deformer_ : *deformer_; }

 private:
  ArticulatedModelOptions options_;
  OccupancyNetwork occupancy_{nullptr};
  std::shared_ptr<MlpSkinningField> skinning_;
  std::unique_ptr<Deformer> deformer_, frozen_deformer_;
  PoseEncoder pose_encoder_{nullptr};
  Pin pin_canonical_{nullptr}, pin_deformed_{nullptr};
  // A PIN applied in the networks' normalised coordinates, so its rotations
  // turn about the body's centre rather than the canonical origin (the feet).
  torch::Tensor through_pin(Pin& pin, const torch::Tensor& x, const torch::Tensor& pose_embedding, bool inverse);
};

}  // namespace fskin
