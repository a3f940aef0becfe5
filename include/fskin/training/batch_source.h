#pragma once
// What training needs from data, behind a small interface so tests can feed
// in-memory frames and the CLI the on-disk Dataset.
#include <torch/types.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fskin/data/canonical_skeleton.h"

namespace fskin {

struct OccupancyBatch {
  torch::Tensor points;           // [B, N, 3] posed space
  torch::Tensor occupancy;        // [B, N] float 0/1
  torch::Tensor bone_transforms;  // [B, J, 4, 4] canonical -> posed
  torch::Tensor pose;             // [B, J, 3] axis-angle
};

class BatchSource {
 public:
  virtual ~BatchSource() = default;
  virtual int64_t num_frames() const = 0;
  virtual const CanonicalSkeleton& skeleton() const = 0;
  // `frames` frames x (surface_points near-surface + uniform_points uniform)
  // points; the same seed gives the same batch.
  virtual OccupancyBatch batch(int64_t frames, int64_t surface_points, int64_t uniform_points,
                               uint64_t seed) const = 0;
};

}  // namespace fskin
