#include "fskin/evaluation/evaluation_frame.h"

#include <torch/torch.h>

namespace fskin {

std::vector<OccupancyFrame> evaluation_frames(const Dataset& dataset) {
  std::vector<OccupancyFrame> frames;
  for (int64_t i = 0; i < dataset.size(); ++i) {
    const auto& f = dataset.frame(i);
    frames.push_back({f.points, f.occupancy.to(torch::kFloat32), f.num_uniform, f.bone_transforms, f.pose});
  }
  return frames;
}

}  // namespace fskin
