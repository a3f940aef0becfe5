#include "fskin/training/dataset_source.h"

#include <torch/torch.h>

#include "fskin/core/error.h"

namespace fskin {

DatasetBatchSource::DatasetBatchSource(const Dataset& dataset)
    : dataset_(dataset), skeleton_(canonical_skeleton(dataset)) {}

OccupancyBatch DatasetBatchSource::batch(int64_t frames, int64_t surface_points, int64_t uniform_points,
                                         uint64_t seed) const {
  Rng rng(seed);
  auto b = dataset_.sample_batch(frames, surface_points, uniform_points, rng);
  return {b.points, b.occupancy, b.bone_transforms.to(torch::kFloat32), b.pose.to(torch::kFloat32)};
}

}  // namespace fskin
