#pragma once
// The CPU / CUDA dispatch keys' kernel of fskin::composite_rays, callable without the
// dispatcher: the benchmark of the dispatcher's overhead calls it directly.
#include <c10/util/ArrayRef.h>
#include <torch/types.h>

#include <tuple>

namespace fskin {

std::tuple<torch::Tensor, torch::Tensor> composite_rays_kernel(const torch::Tensor& sigma, const torch::Tensor& rgb, const torch::Tensor& delta,
                                                               const torch::Tensor& background);

}  // namespace fskin
