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

namespace fskin {

enum class Method { FastSnarf, Snarf };
Method parse_method(const std::string& name);  // "fast-snarf" | "snarf"
std::string method_name(Method method);

enum class Aggregation { Soft, Max };

struct ArticulatedModelOptions {
  Method method = Method::FastSnarf;
  OccupancyNetworkOptions occupancy;  // pose_dim > 0 enables pose conditioning
  MlpSkinningFieldOptions skinning;
  VoxelBox box;  // Fast-SNARF's skinning grid (and its validity region)
  DeformerOptions deformer = DeformerOptions::fast_snarf();
};

struct OccupancyPrediction {
  torch::Tensor logits;  // [B, N]
  DeformerStats deformer;
  double deformer_seconds = 0, shape_seconds = 0, aggregation_seconds = 0;
};

// SNARF's pose condition: the axis-angles of every joint but the root
// (global orientation), divided by pi. pose [B, J, 3] -> [B, 3 (J - 1)].
torch::Tensor pose_condition(const torch::Tensor& pose);

class ArticulatedOccupancyModel : public torch::nn::Module {
 public:
  explicit ArticulatedOccupancyModel(const ArticulatedModelOptions& options);

  // Posed points [B, N, 3], bones [B, J, 4, 4] canonical -> posed, pose [B, J, 3].
  OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones,
                              const torch::Tensor& pose, Aggregation aggregation);
  // Canonical occupancy logits at canonical points [B, M, 3].
  torch::Tensor canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose);
  // Skinning weights the deformer uses at canonical points [..., 3] -> [..., J].
  torch::Tensor skinning_weights(const torch::Tensor& x_canonical);

  // Fast-SNARF: fix the distilled grid (no MLP pass per query) until the next
  // train(true). Call before evaluation; a no-op for SNARF.
  void freeze_for_inference();
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
