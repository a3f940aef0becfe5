#pragma once
// Image quality of renders against ground truth, as the avatar papers report it.
#include <torch/types.h>

namespace fskin {

// Peak signal-to-noise ratio in dB of images [H, W, 3] in [0, 1] (float):
// -10 log10(mean squared error); infinity for identical images.
double psnr(const torch::Tensor& image, const torch::Tensor& reference);
// Structural similarity (Wang et al. 2004): 11 x 11 Gaussian window (sigma
// 1.5), C1 = (0.01)^2, C2 = (0.03)^2, per channel, averaged over the valid
// window positions and the channels.
double ssim(const torch::Tensor& image, const torch::Tensor& reference);
// The same SSIM as a differentiable scalar tensor in the image's dtype and
// device (a training loss: 1 - SSIM, as 3D Gaussian splatting uses).
torch::Tensor ssim_tensor(const torch::Tensor& image, const torch::Tensor& reference);

}  // namespace fskin
