#pragma once
// What training, evaluation and meshing need from a method that predicts the
// occupancy of posed points: SNARF and Fast-SNARF (articulated_occupancy_model.h),
// INS, and the baselines of SNARF sec. 4.2 (baselines/). The trainer only sees
// this interface, so every method trains, resumes and evaluates the same way.
#include <torch/torch.h>

#include <vector>

#include "fskin/deformers/deformer.h"
#include "fskin/fields/skinning_field.h"
#include "fskin/training/batch_source.h"

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

// Inputs of the first-epoch bootstrap losses (SNARF sec. 3.3).
struct BootstrapInputs {
  const CanonicalSkeleton* skeleton = nullptr;
  torch::Tensor bone_points;  // [S, 3] canonical points on the bones
  torch::Tensor pose;         // [B, J, 3] the batch's poses (shape condition)
  double joint_weight = 10;   // weight of the joint skinning-weight loss
};

// SNARF's pose condition: the axis-angles of every joint but the root
// (global orientation), divided by pi. pose [B, J, 3] -> [B, 3 (J - 1)].
torch::Tensor pose_condition(const torch::Tensor& pose);

// Posed points [B, N, 3] in the frame of the root bone: its canonical ->
// posed transform undone, so posed-space networks do not have to learn the
// global orientation and translation (bones [B, J, 4, 4]).
torch::Tensor to_root_frame(const torch::Tensor& points, const torch::Tensor& bones);

class OccupancyModel : public torch::nn::Module {
 public:
  // Posed points [B, N, 3], bones [B, J, 4, 4] canonical -> posed, pose [B, J, 3]
  // -> occupancy logits [B, N].
  virtual OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones,
                                      const torch::Tensor& pose, Aggregation aggregation) = 0;

  // The bootstrap losses that apply to this method, weighted and summed; an
  // undefined tensor when none does (methods without a canonical space).
  virtual torch::Tensor bootstrap_loss(const BootstrapInputs& inputs);

  // Whether the method has a canonical shape (canonical_logits works).
  virtual bool has_canonical_shape() const { return false; }
  // Canonical occupancy logits at canonical points [B, M, 3] with pose [B, J, 3]
  // as condition; throws fskin::Error for methods without a canonical shape.
  virtual torch::Tensor canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose);

  // Canonical points [B, V, 3] -> posed [B, V, 3] with bones [B, J, 4, 4],
  // keeping vertex correspondences (INS eq. 19); throws fskin::Error for
  // methods without a forward map from canonical space.
  virtual torch::Tensor repose(const torch::Tensor& x_canonical, const torch::Tensor& bones);

  // The learned canonical skinning field, for the skeleton prior's warm start
  // (skinning_prior.h); nullptr for methods without one.
  virtual SkinningField* canonical_skinning_field() { return nullptr; }

  // Fixes what can be precomputed for inference (Fast-SNARF's grid) until the
  // next train(true).
  virtual void freeze_for_inference() {}

  // Optimiser groups as (parameters, learning rate); by default all at the
  // base rate (INS trains its invertible networks slower).
  struct ParameterGroup {
    std::vector<torch::Tensor> parameters;
    double learning_rate;
  };
  virtual std::vector<ParameterGroup> parameter_groups(double learning_rate);
};

}  // namespace fskin
