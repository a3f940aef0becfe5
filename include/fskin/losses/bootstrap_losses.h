#pragma once
// The two first-epoch losses of SNARF sec. 3.3, computed from the canonical
// skeleton alone (no ground-truth weights or parts): points along the bones
// are occupied, and the skinning weights at each joint are one-hot on that
// joint's own bone.
#include <ATen/core/Generator.h>
#include <torch/types.h>

#include "fskin/fields/skinning_field.h"
#include "fskin/data/canonical_skeleton.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

struct BootstrapInputs {
  const CanonicalSkeleton* skeleton = nullptr;
  torch::Tensor bone_points;  // [S, 3] canonical points on the bones (sample_bone_points)
  torch::Tensor pose;         // [B, J, 3] the batch's poses (shape condition)
  double joint_weight = 10;   // weight of the joint skinning-weight loss
};

// The bootstrap losses that apply to `model`, weighted and summed: bone
// occupancy for models with a canonical shape, plus joint weights for models
// whose deformer queries a skinning field. Undefined when none applies (the
// posed-space baselines).
torch::Tensor bootstrap_loss(OccupancyModel& model, const BootstrapInputs& inputs);

// Per bone segment (parent joint -> joint), `per_bone` points at parameters
// linspace(0, 1, per_bone) + N(0, 0.1) clamped to [0, 1] (reference values).
// -> [S * per_bone, 3] canonical points.
torch::Tensor sample_bone_points(const CanonicalSkeleton& skeleton, int64_t per_bone, at::Generator& generator);

// BCE of the canonical occupancy at bone points against 1, with the batch's
// poses as condition (pose [B, J, 3]).
torch::Tensor bone_occupancy_loss(OccupancyModel& model, const torch::Tensor& bone_points,
                                  const torch::Tensor& pose);

// MSE between the skinning weights at the canonical joints and one-hot on
// each joint's own bone.
torch::Tensor joint_weight_loss(SkinningField& field, const CanonicalSkeleton& skeleton);

}  // namespace fskin
