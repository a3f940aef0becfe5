#pragma once
// The on-disk Dataset (data/dataset.h) as a training batch source.
#include <vector>

#include "fskin/data/dataset.h"
#include "fskin/training/batch_source.h"

namespace fskin {

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


}  // namespace fskin
