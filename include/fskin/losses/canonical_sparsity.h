#pragma once
// An emptiness prior on the canonical shape (fskin's addition, not in the
// papers). The occupancy loss only reaches canonical points that some posed
// sample's correspondence search lands on; everywhere else the canonical field
// keeps what the geometric initialisation said, and the init's "inside"
// survives as floating blobs beside the legs and above the head
// (docs/benchmarks.md, "Canonical floaters"). A small BCE towards "outside" at
// points uniform in the canonical meshing box removes what no posed sample
// supports; near the body the occupancy loss, with far more weight, keeps the
// surface.
#include <ATen/core/Generator.h>
#include <torch/types.h>

#include "fskin/data/point_sampling.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

// Mean BCE of the canonical occupancy against 0 at `points_per_frame` points
// uniform in `box` per frame of the batch, each frame's points conditioned on
// its pose [B, J, 3]. Needs model.has_canonical_shape().
torch::Tensor canonical_sparsity_loss(OccupancyModel& model, const Box& box, const torch::Tensor& pose,
                                      int64_t points_per_frame, at::Generator& generator);

}  // namespace fskin
