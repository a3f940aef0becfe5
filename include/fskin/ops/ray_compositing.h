#pragma once
// Volume-rendering compositing along rays (NeRF's quadrature; Fast-SNARF
// sec. 7, eq. 18-19's renderer): per ray, front to back,
//   alpha_s = 1 - exp(-sigma_s delta_s),  T_s = prod_{k<s} (1 - alpha_k),
//   color = sum_s T_s alpha_s c_s + T_final background,  opacity = 1 - T_final.
// One fused op, a CPU kernel (at::parallel_for over rays) and a CUDA kernel
// (a thread per ray) sharing their per-ray core (src/ops/ray_compositing/),
// with its analytic backward: a second front-to-back pass that keeps the
// prefix sums, so no per-sample state is stored. Samples with delta 0 add
// nothing (padding for rays with fewer samples). No early termination: the
// gradient is that of the full sum. In PyTorch's dispatcher as
// fskin::composite_rays with its backward fskin::_composite_rays_backward;
// Python: torch.ops.fskin.composite_rays.
#include <torch/types.h>

#include <tuple>

namespace fskin {

// sigma [R, S] (>= 0), rgb [R, S, 3], delta [R, S] (>= 0), background [R, 3];
// one dtype (float32 / float64) and device -> (color [R, 3], opacity [R]).
// Differentiable in all four inputs (each gradient is computed only when its
// input requires one).
std::tuple<torch::Tensor, torch::Tensor> composite_rays(const torch::Tensor& sigma, const torch::Tensor& rgb,
                                                        const torch::Tensor& delta, const torch::Tensor& background);

// The same in LibTorch operations (cumprod and sums, autograd's own
// gradients): the reference the fused op is tested and benchmarked against.
std::tuple<torch::Tensor, torch::Tensor> composite_rays_reference(const torch::Tensor& sigma, const torch::Tensor& rgb,
                                                                  const torch::Tensor& delta,
                                                                  const torch::Tensor& background);

}  // namespace fskin
