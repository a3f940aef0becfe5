#pragma once
// The on-disk Dataset (data/dataset.h) as a training batch source and as
// evaluation frames.
#include <vector>

#include "fskin/data/dataset.h"
#include "fskin/training/batch_source.h"

namespace fskin {

// The canonical skeleton of a dataset: SMPL parents by joint name, the body's
// canonical mesh as extent, and canonical joint positions estimated from the
// frames' rest -> posed bone transforms (the manifest stores no joints): for a
// joint j with parent p, every frame's G_p^-1 G_j rotates about the rest joint
// r_j, so r_j solves sum_k |(I - R_k) r - t_k|^2, regularised towards the
// parent's joint where the frames rotate about one axis only (a knee). The
// root uses G_0 minus the root translation.
CanonicalSkeleton canonical_skeleton(const Dataset& dataset);

class DatasetBatchSource : public BatchSource {
 public:
  explicit DatasetBatchSource(const Dataset& dataset);
  int64_t num_frames() const override { return dataset_.size(); }
  const CanonicalSkeleton& skeleton() const override { return skeleton_; }
  OccupancyBatch batch(int64_t frames, int64_t surface_points, int64_t uniform_points,
                       uint64_t seed) const override;

 private:
  const Dataset& dataset_;
  CanonicalSkeleton skeleton_;
};

std::vector<OccupancyFrame> evaluation_frames(const Dataset& dataset);

}  // namespace fskin
