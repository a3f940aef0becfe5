#pragma once
// Pose inputs the models share.
#include <torch/types.h>

namespace fskin {

// SNARF's pose condition: the axis-angles of every joint but the root
// (global orientation), divided by pi. pose [B, J, 3] -> [B, 3 (J - 1)].
torch::Tensor pose_condition(const torch::Tensor& pose);

// Posed points [B, N, 3] in the frame of the root bone: its canonical ->
// posed transform undone, so posed-space networks do not have to learn the
// global orientation and translation (bones [B, J, 4, 4]).
torch::Tensor to_root_frame(const torch::Tensor& points, const torch::Tensor& bones);

}  // namespace fskin
