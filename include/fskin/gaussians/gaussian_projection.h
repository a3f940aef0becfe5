#pragma once
// 3-D Gaussians to the 2-D Gaussians the rasteriser draws
// (fskin/ops/gaussian_rasterization.h): EWA splatting's local affine
// approximation of the pinhole projection (Zwicker et al. 2002; 3DGS, Kerbl et
// al. 2023, eq. 5): Sigma' = J W Sigma W^T J^T, with W the camera's rotation
// and J the projection's Jacobian at the Gaussian's mean, plus a screen-space
// dilation (0.3 pixel^2 by default, as 3DGS; the Gaussian avatar draws with
// its own, 0.1) so that no footprint is thinner than about a pixel.
//
// The dilation widens small footprints: a Gaussian under a pixel wide, fitted
// from near cameras, draws a thicker and more opaque rim from far ones (the
// silhouettes of the demo's held-out cameras, 16 % farther, came out 7 % too
// large in area). `opacity_compensation` is Mip-Splatting's 2-D filter factor
// (Yu et al. 2024, eq. 9; gsplat's "antialiased" mode),
//   rho = sqrt(det(Sigma') / det(Sigma' + s I)),
// which keeps a footprint's integrated opacity as the dilation spreads it;
// computed when `compensate` asks for it, the caller multiplies opacities by
// it when it renders antialiased.
//
// Per-Gaussian algebra in LibTorch operations on [N] tensors, differentiable
// by autograd; the pixel loop, where fusion pays, is the rasteriser's op.
#include <torch/types.h>

#include "fskin/geometry/pinhole_camera.h"

namespace fskin {

struct ProjectionOptions {
  double near = 0.01;     // Gaussians nearer than this along the view (camera z) are not drawn
  double dilation = 0.3;  // added to the 2-D covariance's diagonal, pixels^2
  double extent = 3.0;    // a footprint's radius in standard deviations of its widest axis
  bool compensate = false;  // also return opacity_compensation
};

struct ProjectedGaussians {
  torch::Tensor means2d;  // [N, 2] (u, v) pixels, OpenCV's convention
  torch::Tensor conics;   // [N, 3] (a, b, c): the inverse 2-D covariance [[a, b], [b, c]]
  torch::Tensor depths;   // [N] camera z
  torch::Tensor radii;    // [N] pixels, 0 where not drawn (behind `near`, degenerate); no gradient
  torch::Tensor opacity_compensation;  // [N] rho above, in [0, 1] (1 where not drawn); differentiable;
                                       // undefined unless options.compensate
};

// Covariances R diag(s)^2 R^T [N, 3, 3] of Gaussians with scales [N, 3]
// (standard deviations along their axes) and rotations [N, 4] as quaternions
// (w, x, y, z), normalised here.
torch::Tensor gaussian_covariances(const torch::Tensor& scales, const torch::Tensor& rotations);

// Means [N, 3] and covariances [N, 3, 3] in world space, seen by `camera`.
// float32 or float64, any device; differentiable in means and covariances.
ProjectedGaussians project_gaussians(const torch::Tensor& means, const torch::Tensor& covariances,
                                     const PinholeCamera& camera, const ProjectionOptions& options = {});

}  // namespace fskin
