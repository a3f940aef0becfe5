#pragma once
// A Gaussian avatar as a file other programs read: a binary little-endian PLY
// whose `vertex` element is 3D Gaussian splatting's own layout (x y z, nx ny
// nz, f_dc_0..2, f_rest_*, opacity as a logit, scale_0..2 as logs, rot_0..3 a
// quaternion w x y z), so 3DGS viewers show the canonical avatar as it is,
// plus what posing it needs (docs/gaussian_avatars.md, "Export"):
//   weight_0 .. weight_{J-1}    every joint's skinning weight (rows sum to 1)
//   element joint J             parent (int), x y z: the canonical joints;
//                               names in `comment joint_name <j> <name>` lines
//   element bone_transform F*J  (with an animation) m00 .. m33, row-major 4 x 4
//                               canonical -> posed transforms, frame by frame;
//                               `comment fps <f>`
//   `comment antialiased`       the avatar was trained with opacities scaled
//                               by the dilation's compensation
//                               (gaussian_projection.h), as its renders are
//   `comment dilation <d>`      the screen-space dilation its footprints are
//                               drawn with, pixels^2 (3DGS viewers: 0.3)
// A reader poses Gaussian i in a frame as fskin does: T = sum_j w_ij B_j,
// mean' = T mean, covariance' = A R S S R^T A^T (A: T's 3 x 3 part). An
// avatar's non-rigid offsets (non_rigid_offset.h) depend on the pose through
// a network and are in neither file: players pose by skinning alone. Nor is
// the learned lighting of an avatar with shading (gaussian_shading.h): the
// colours written are the albedo, for a player's own lights to shade.
#include <torch/types.h>

#include <string>

#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

// What an exported file animates and how (gaussian_gltf.h, write_gaussian_avatar_file).
struct GaussianExportOptions {
  torch::Tensor bones;  // [F, J, 4, 4] canonical -> posed, an animation; undefined: none
  double fps = 30;
  // glTF only (the PLY keeps every weight): influences per Gaussian, the
  // largest weights, renormalised, in sets of four (4: what every engine
  // reads); 0 keeps every joint's weight.
  int64_t influences = 4;
  std::string animation_name = "poses";
};

// bones: [F, J, 4, 4] for an animation, or undefined. Written atomically;
// errors name `path`.
void write_gaussian_ply(const std::string& path, GaussianAvatarImpl& avatar, const Skeleton& skeleton,
                        const torch::Tensor& bones = {}, double fps = 30);

// By path's extension: .ply as above, .glb / .gltf as gaussian_gltf.h;
// anything else is an error naming path. What `fskin avatar export` and
// Python's export_avatar write for a Gaussian run.
void write_gaussian_avatar_file(const std::string& path, GaussianAvatarImpl& avatar, const Skeleton& skeleton,
                                const GaussianExportOptions& options = {});

}  // namespace fskin
