#include "fskin/training/dataset_source.h"

#include <torch/torch.h>

#include "fskin/core/error.h"

namespace fskin {

CanonicalSkeleton canonical_skeleton(const Dataset& dataset) {
  const auto& canonical = dataset.canonical();
  CanonicalSkeleton s;
  s.joint_names = dataset.joint_names();
  s.parents = dataset.parents();
  s.joints = canonical.joints.to(torch::kFloat32);
  // The canonical mesh when there is one (the stick set has only its box).
  s.extent = (canonical.vertices.defined() && canonical.vertices.size(0) > 0 ? canonical.vertices : canonical.box)
                 .to(torch::kFloat32);
  return s;
}

DatasetBatchSource::DatasetBatchSource(const Dataset& dataset)
    : dataset_(dataset), skeleton_(canonical_skeleton(dataset)) {}

OccupancyBatch DatasetBatchSource::batch(int64_t frames, int64_t surface_points, int64_t uniform_points,
                                         uint64_t seed) const {
  Rng rng(seed);
  auto b = dataset_.sample_batch(frames, surface_points, uniform_points, rng);
  return {b.points, b.occupancy, b.bone_transforms.to(torch::kFloat32), b.pose.to(torch::kFloat32)};
}

std::vector<OccupancyFrame> evaluation_frames(const Dataset& dataset) {
  std::vector<OccupancyFrame> frames;
  for (int64_t i = 0; i < dataset.size(); ++i) {
    const auto& f = dataset.frame(i);
    frames.push_back({f.points, f.occupancy.to(torch::kFloat32), f.num_uniform, f.bone_transforms, f.pose});
  }
  return frames;
}

}  // namespace fskin
