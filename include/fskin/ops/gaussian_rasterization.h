#pragma once
// Differentiable rasterisation of projected 2-D Gaussians (3D Gaussian
// splatting's image formation, Kerbl et al. 2023, eq. 2-3): the picture is cut
// into 16 x 16 tiles; each Gaussian is listed in the tiles its 2-D extent
// (`radii`, in pixels) touches, each tile's list is sorted front to back by
// depth, and every pixel alpha-blends its tile's Gaussians front to back,
// stopping once its transmittance would fall under 1e-4 (thresholds in
// src/ops/gaussian_rasterization/gaussian_rasterization_kernel.h).
//
// One op in PyTorch's dispatcher, fskin::rasterize_gaussians; under autograd
// it runs fskin::_rasterize_gaussians_forward, which also returns the tile
// lists, and its analytic backward fskin::_rasterize_gaussians_backward walks
// those lists once more per pixel, with the pixel's colour and transmittance
// taken from the forward's outputs (nothing else per pixel is stored). A CPU
// kernel (at::parallel_for over tiles, Gaussian by Gaussian over the pixels
// each can reach) and a CUDA kernel (a thread per pixel) share the
// per-Gaussian, per-pixel steps. Written here rather than taken from the 3DGS
// authors' rasteriser, whose licence forbids commercial use.
//
// Binning and sorting are LibTorch operations on a GPU and a counting sort
// over the tiles on the CPU (the same lists); ties in depth keep the
// Gaussians' order, so a scene renders the same on every run.
#include <torch/types.h>

#include <tuple>

namespace fskin {

// means2d [N, 2] (u, v) in pixels with pixel column u's centre at u (OpenCV's
// convention, docs/conventions.md "Cameras"); conics [N, 3] (a, b, c), the
// inverse 2-D covariance [[a, b], [b, c]]; colors [N, C] with 1 <= C <= 16;
// opacities [N] in [0, 1]; depths [N] (the sort key; smaller is nearer);
// radii [N] (pixels; a Gaussian with radius <= 0 is not drawn); background [C].
// One floating dtype (float32 / float64) and device -> (image [H, W, C],
// alpha [H, W]). Differentiable in means2d, conics, colors, opacities and
// background; depths and radii take no gradient.
std::tuple<torch::Tensor, torch::Tensor> rasterize_gaussians(const torch::Tensor& means2d, const torch::Tensor& conics,
                                                             const torch::Tensor& colors,
                                                             const torch::Tensor& opacities,
                                                             const torch::Tensor& depths, const torch::Tensor& radii,
                                                             const torch::Tensor& background, int64_t width,
                                                             int64_t height);

// The same picture from dense LibTorch operations over every pixel and every
// Gaussian (the same tiles, order, thresholds and early stop; autograd's own
// gradients): the reference the op is tested against. Memory grows with
// pixels x Gaussians: for tests and small scenes.
std::tuple<torch::Tensor, torch::Tensor> rasterize_gaussians_reference(
    const torch::Tensor& means2d, const torch::Tensor& conics, const torch::Tensor& colors,
    const torch::Tensor& opacities, const torch::Tensor& depths, const torch::Tensor& radii,
    const torch::Tensor& background, int64_t width, int64_t height);

}  // namespace fskin
