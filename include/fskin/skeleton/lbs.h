#pragma once
// Linear blend skinning (SNARF eq. 4): x' = sum_i w_i(x) B_i x, with column
// vectors and homogeneous 4x4 transforms. Batched, differentiable.
#include <torch/types.h>

namespace fskin {

// Blended transforms T(x) = sum_i w_i B_i.
// weights [B, N, J] (or [N, J], shared across the batch), bones [B, J, 4, 4]
// -> [B, N, 4, 4].
torch::Tensor blend_transforms(const torch::Tensor& weights, const torch::Tensor& bones);

// Apply transforms [..., 4, 4] to points [..., 3] (broadcasting leading dims).
torch::Tensor transform_points(const torch::Tensor& transforms, const torch::Tensor& points);

// LBS of points [B, N, 3] with weights [B, N, J] or [N, J] and bones [B, J, 4, 4].
torch::Tensor linear_blend_skinning(const torch::Tensor& points, const torch::Tensor& weights,
                                    const torch::Tensor& bones);

// Homogeneous transforms [..., 4, 4] from rotations [..., 3, 3] and translations [..., 3].
torch::Tensor make_transform(const torch::Tensor& rotation, const torch::Tensor& translation);

// Inverse of general affine transforms [..., 4, 4] (rotation, scale, shear).
// Throws fskin::Error if any 3x3 block is singular or the input is not finite.
torch::Tensor invert_transforms(const torch::Tensor& transforms);

// The same inverse without reading anything back to the host: `invertible` is
// a bool scalar on the transforms' device (all finite and every |det| >
// 1e-8), for callers that fold that check into a read they make anyway (the
// deformer on CUDA). Where it is false the inverse is meaningless.
struct TransformInverse {
  torch::Tensor inverse, invertible;
};
TransformInverse invert_transforms_on_device(const torch::Tensor& transforms);

}  // namespace fskin
