#pragma once
// The interface every model fskin trains implements: a method that predicts
// the occupancy of posed points. SNARF and Fast-SNARF (forward_skinning_model.h),
// INS (ins_model.h) and the baselines of SNARF sec. 4.2 (baselines/). The
// trainer, the losses, evaluation and meshing see only this interface, so every
// method trains, resumes and evaluates the same way; model_registry.h builds one.
#include <torch/torch.h>

#include <vector>

#include "fskin/deformers/deformer.h"
#include "fskin/fields/skinning_field.h"

namespace fskin {

// How candidates (canonical correspondences, or parts) are combined: the
// papers' soft max in training, the hard max at evaluation (SNARF eq. 9).
enum class Aggregation { Soft, Max };

struct OccupancyPrediction {
  torch::Tensor logits;  // [B, N]
  DeformerStats deformer;  // correspondence statistics (forward-skinning methods)
  // Where the time went: posed -> canonical mapping, shape network, aggregation.
  double deformer_seconds = 0, shape_seconds = 0, aggregation_seconds = 0;
};

class OccupancyModel : public torch::nn::Module {
 public:
  // Posed points [B, N, 3], bones [B, J, 4, 4] canonical -> posed, pose [B, J, 3]
  // -> occupancy logits [B, N].
  virtual OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones,
                                      const torch::Tensor& pose, Aggregation aggregation) = 0;

  // Whether the method has a canonical shape (canonical_logits works).
  virtual bool has_canonical_shape() const { return false; }
  // Canonical occupancy logits at canonical points [B, M, 3] with pose [B, J, 3]
  // as condition; throws fskin::Error for methods without a canonical shape.
  virtual torch::Tensor canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose);

  // Canonical points [B, V, 3] -> posed [B, V, 3] with bones [B, J, 4, 4],
  // keeping vertex correspondences (INS eq. 19); throws fskin::Error for
  // methods without a forward map from canonical space.
  virtual torch::Tensor repose(const torch::Tensor& x_canonical, const torch::Tensor& bones);

  // The learned canonical skinning network (the skeleton prior's warm start,
  // losses/skinning_prior.h; the posed meshing box); nullptr for methods
  // without one.
  virtual SkinningField* canonical_skinning_field() { return nullptr; }
  // The skinning field the deformer queries (Fast-SNARF: the grid distilled
  // from the network), which the joint-weight bootstrap loss supervises;
  // nullptr for methods without a deformer.
  virtual SkinningField* deformer_skinning_field() { return nullptr; }

  // The canonical occupancy network's coarse-to-fine frequency window
  // (networks/frequency_encoding.h); a no-op for models without a frequency encoding.
  virtual void set_frequency_window(double window) { (void)window; }

  // Fixes what can be precomputed for inference (Fast-SNARF's grid) until the
  // next train(true).
  virtual void freeze_for_inference() {}

  // Optimiser groups as (parameters, learning rate); together they hold every
  // parameter once. By default all at the base rate.
  struct ParameterGroup {
    std::vector<torch::Tensor> parameters;
    double learning_rate;
  };
  virtual std::vector<ParameterGroup> parameter_groups(double learning_rate);
};

}  // namespace fskin
