#pragma once
// What evaluation reads from data: posed frames with ground-truth occupancy.
#include <torch/types.h>

#include <cstdint>
#include <vector>

#include "fskin/data/dataset.h"

namespace fskin {

// One evaluation frame: the first num_uniform points are uniform in the box
// (IoU_bbox), the rest near the surface (IoU_surf).
struct OccupancyFrame {
  torch::Tensor points;           // [N, 3]
  torch::Tensor occupancy;        // [N]
  int64_t num_uniform = 0;
  torch::Tensor bone_transforms;  // [J, 4, 4]
  torch::Tensor pose;             // [J, 3]
};

// Every frame of an on-disk dataset split.
std::vector<OccupancyFrame> evaluation_frames(const Dataset& dataset);

}  // namespace fskin
