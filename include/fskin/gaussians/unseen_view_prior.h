#pragma once
// The unseen-view prior of a Gaussian avatar (losses.alpha_entropy): with a
// few training cameras, nothing in the images fixes how the avatar looks from
// between them. Each training step then also draws the step's pose from an
// unseen view, the step's camera turned about its picture's vertical axis
// through the posed avatar's centre by an angle drawn uniformly within
// +-losses.unseen_view.degrees (the rig silhouette prior,
// rig_silhouette_prior.h, reads the same picture), and adds the weight times
// the binary entropy of that picture's opacity, -(a ln a + (1 - a) ln(1 - a)),
// summed over its pixels and divided by the training picture's pixel count
// (as the other losses are normalised). It asks every view for a subject that
// covers each pixel fully or not at all: a solid body, not a haze of
// half-transparent Gaussians that the training cameras happen to see as one.
// It uses no mask and assumes nothing of the subject's shape, so it holds for
// clothing and for any rig.
//
// Why it is off by default: alone it gains the demo's lit and unlit images
// 0.5-0.6 dB (3 seeds), but with the rig silhouette prior, on by default, it
// gains nothing (seed 0; docs/benchmarks.md, "Gaussian avatars"). Where that
// prior is off (captures), it is the one that holds for clothing.
#include <torch/torch.h>

#include <Eigen/Core>

#include "fskin/geometry/pinhole_camera.h"

namespace fskin {

// `camera` turned by `radians` about its picture's vertical axis (its down())
// through `pivot`: the pivot keeps its pixel and its distance from the eye.
// No world axis is assumed.
PinholeCamera unseen_view(const PinholeCamera& camera, double radians, const Eigen::Vector3d& pivot);

// The sum over the pixels of alpha [H, W] of -(a ln a + (1 - a) ln(1 - a)),
// alpha clamped to [1e-4, 1 - 1e-4] so that the gradient stays finite.
torch::Tensor alpha_entropy_sum(const torch::Tensor& alpha);

}  // namespace fskin
