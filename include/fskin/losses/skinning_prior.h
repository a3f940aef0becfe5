#pragma once
// A skinning prior computed from the skeleton alone (no ground-truth weights):
// every canonical point belongs to the bone whose segment is nearest. SNARF's
// bootstrap (sec. 3.3) asks for one-hot weights only at the joints; with that
// alone, the first hundreds of steps see nearly random weights, roots land in
// the wrong places and the occupancy network learns from them. On our CPU
// budget (hundreds of steps, not 45k) that start never recovered, so training
// first fits the skinning network to this prior (a warm start) and then
// learns freely from the posed data: the prior is a starting point, not a
// target.
#include <torch/types.h>

#include "fskin/fields/skinning_field.h"
#include "fskin/data/canonical_skeleton.h"

namespace fskin {

// One-hot [M, J] weights of canonical points [M, 3]: the bone that moves the
// nearest segment (parent joint p -> joint j moves with bone p).
torch::Tensor nearest_bone_weights(const CanonicalSkeleton& skeleton, const torch::Tensor& points);

// Points to fit the prior at: the skeleton's extent points and uniform points
// in their box enlarged by 20 %, `count` in all, from `seed`.
torch::Tensor skinning_prior_points(const CanonicalSkeleton& skeleton, int64_t count, uint64_t seed);

// `steps` Adam steps (learning rate `learning_rate`) of the cross-entropy
// between the field's weights and the prior at the prior points; returns the
// final mean cross-entropy.
double fit_skinning_prior(SkinningField& field, const CanonicalSkeleton& skeleton, int64_t steps,
                          double learning_rate, uint64_t seed);

}  // namespace fskin
