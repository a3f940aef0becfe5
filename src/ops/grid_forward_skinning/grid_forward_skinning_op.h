#pragma once
// The CPU / CUDA dispatch keys' kernel of fskin::grid_forward_skinning, callable without the
// dispatcher: the benchmark of the dispatcher's overhead calls it directly.
#include <c10/util/ArrayRef.h>
#include <torch/types.h>

#include <tuple>

namespace fskin {

torch::Tensor grid_forward_skinning_kernel(const torch::Tensor& transform_grid, c10::ArrayRef<double> box_offset,
                                           c10::ArrayRef<double> box_scale, const torch::Tensor& x_canonical);

}  // namespace fskin
