#pragma once
// What training and evaluation need from data, behind a small interface so
// tests can feed in-memory frames and the CLI the on-disk Dataset.
#include <torch/types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace fskin {

struct OccupancyBatch {
  torch::Tensor points;           // [B, N, 3] posed space
  torch::Tensor occupancy;        // [B, N] float 0/1
  torch::Tensor bone_transforms;  // [B, J, 4, 4] canonical -> posed
  torch::Tensor pose;             // [B, J, 3] axis-angle
};

// One evaluation frame: the first num_uniform points are uniform in the box
// (IoU_bbox), the rest near the surface (IoU_surf).
struct OccupancyFrame {
  torch::Tensor points;           // [N, 3]
  torch::Tensor occupancy;        // [N]
  int64_t num_uniform = 0;
  torch::Tensor bone_transforms;  // [J, 4, 4]
  torch::Tensor pose;             // [J, 3]
};

// The skeleton in canonical space, for the bootstrap losses and the voxel box.
struct CanonicalSkeleton {
  std::vector<std::string> joint_names;
  std::vector<int64_t> parents;  // parents[0] == -1, parents[j] < j
  torch::Tensor joints;          // [J, 3] canonical joint positions
  torch::Tensor extent;          // [M, 3] points whose bounding box the canonical body fills
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
