#pragma once
// A Gaussian avatar as a skinned glTF 2.0 asset with the Khronos extension
// KHR_gaussian_splatting (its 2026 text): one POINTS primitive whose
// attributes are the canonical Gaussians,
//   POSITION                                   means (the bind pose)
//   KHR_gaussian_splatting:ROTATION            unit quaternions (x, y, z, w)
//   KHR_gaussian_splatting:SCALE               standard deviations (linear)
//   KHR_gaussian_splatting:OPACITY             in (0, 1), after the sigmoid
//   KHR_gaussian_splatting:SH_DEGREE_l_COEF_n  spherical harmonics (RGB),
//                                              3DGS's basis and 0.5 bias
//   COLOR_0                                    the point-cloud fallback: the
//                                              degree-0 colour and opacity
//   JOINTS_n / WEIGHTS_n                       the skinning weights
// with the primitive's extension object {kernel "ellipse", colorSpace
// "srgb_rec709_display", projection "perspective", sortingMethod
// "cameraDistance"}, and the skeleton, skin and animation of the skinned
// mesh export (fskin/export/skinned_gltf.h: joint frames, inverse bind
// matrices, channels).
//
// A player poses Gaussian i as fskin does: T = sum_j w_ij (G_j IBM_j) with
// G_j the joint node's global matrix, mean' = T mean, covariance' =
// A R S S R^T A^T (A: T's 3 x 3 part), and evaluates the spherical harmonics
// at the view direction mapped back by A^T. The primitive's
// extras.fskin.antialiased says whether opacities are to be multiplied by
// the dilation's compensation (gaussians/gaussian_projection.h) as the
// avatar was trained, extras.fskin.dilation the dilation in pixels^2;
// players without them draw small Gaussians slightly more opaque and wider.
#include <torch/types.h>

#include <string>

#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/gaussians/gaussian_export.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

// Writes `avatar` posed by `skeleton` to path (.glb or .gltf) atomically;
// errors name `path`.
void write_gaussian_gltf(const std::string& path, GaussianAvatarImpl& avatar, const Skeleton& skeleton,
                         const GaussianExportOptions& options = {});

}  // namespace fskin
