#pragma once
// The opacity prior of a Gaussian avatar (losses.opacity): the binary entropy
// of each Gaussian's opacity, zero for an opaque or a vanished Gaussian and
// largest at one half (SuGaR, Guedon and Lepetit 2024, sec. 4.1, which
// pushes opacities toward 0 or 1 so that the Gaussians form a surface).
//
// Why it is an option and not a default: on the demo's lit images
// (irradiance shading) it gains 0.23 / 0.16 dB over the subject's box and
// narrows the seeds' spread, on the unlit ones it loses 0.38 / 0.38 dB
// (novel views / poses, 3 seeds each; docs/benchmarks.md, "Gaussian avatars").
#include <torch/torch.h>

#include "fskin/gaussians/gaussian_avatar.h"

namespace fskin {

// The mean over Gaussians of -(o ln o + (1 - o) ln(1 - o)), o the opacities
// (o clamped to [1e-6, 1 - 1e-6] so that the gradient stays finite).
torch::Tensor opacity_entropy(const GaussianAvatarImpl& avatar);

}  // namespace fskin
