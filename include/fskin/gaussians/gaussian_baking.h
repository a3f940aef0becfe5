#pragma once
// A Gaussian avatar as a rigged mesh for engines that draw no Gaussians
// (`fskin avatar export RUN --mesh`): the character's own canonical mesh,
// subdivided so that its vertices lie about as close together as the
// Gaussians (geometry/mesh_subdivision.h), each vertex coloured by what a
// camera looking straight down its normal sees of the canonical Gaussians.
//
// The colour at a surface point p with outward normal n: a ray from
// o = p + h n towards -n (h: 3 initial spacings, above the layer the
// Gaussians sink to, gaussians/surface_layer.h), through the Gaussians whose
// means are the k nearest to p. Each meets the ray where its density peaks,
//   t_i = d^T S_i^-1 (mu_i - o) / (d^T S_i^-1 d),  d = -n,
// with the peak's alpha_i = min(0.99, opacity_i exp(-(q^T S_i^-1 q - t_i^2 d^T S_i^-1 d) / 2)),
// q = mu_i - o (the maximum response along the ray of 3D Gaussian ray
// tracing, Moenne-Loccoz et al. 2024), and they blend front to back as the
// rasteriser blends them (ops/gaussian_rasterization.h):
//   colour = sum_i T_i alpha_i c_i / sum_i T_i alpha_i,  T_i = prod_{k < i} (1 - alpha_k),
// c_i the Gaussian's spherical harmonics seen along d, divided by the
// coverage so that no background mixes in. Only Gaussians met within
// 2 h of o take part (the body's far side stays out); a point no Gaussian
// covers, or without a normal (zero: where opposite faces meet), takes its
// nearest Gaussian's colour. An avatar trained with
// learned skinning corrections has its weights blended the same way (the
// rig's own weights otherwise, which the Gaussians carry unchanged). Shading
// (gaussian_shading.h) is left out, as in every export: the colours are the
// albedo; with appearance codes (gaussian_appearance.h), at code zero, the
// frames' average. Non-rigid offsets, which depend on the pose, are not in a mesh.
#include <torch/types.h>

#include <array>
#include <string>

#include "fskin/geometry/pinhole_camera.h"
#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/gaussians/gaussian_export.h"
#include "fskin/skeleton/rigged_mesh.h"

namespace fskin {

struct GaussianBakingOptions {
  // Midpoint subdivisions of the character's mesh (0: its own vertices; each
  // multiplies the faces by 4). -1: the fewest that bring the vertices to at
  // least the Gaussians' number.
  int64_t subdivisions = -1;
  int64_t neighbours = 32;  // Gaussians considered per vertex (the nearest means)
  void validate() const;
};

// What the Gaussians show at surface points.
struct BakedSurface {
  torch::Tensor colors;    // [M, 3] float in [0, 1]
  torch::Tensor coverage;  // [M] the blended opacity along the ray, in [0, 1]
  torch::Tensor weights;   // [M, J] blended skinning weights (rows sum to 1); undefined unless asked
};

// points [M, 3], normals [M, 3] (unit, outward) in canonical space.
BakedSurface bake_gaussians_at(GaussianAvatarImpl& avatar, const torch::Tensor& points, const torch::Tensor& normals,
                               const GaussianBakingOptions& options = {}, bool blend_weights = false);

// The character's canonical mesh with colours (8-bit, Mesh::colors) baked
// from the avatar and its skinning weights (the rig's, or blended where the
// avatar learned corrections), subdivided as options say.
RiggedMesh baked_gaussian_mesh(GaussianAvatarImpl& avatar, const RiggedMesh& character,
                               const GaussianBakingOptions& options = {});

// A baked mesh posed by linear blend skinning with bones [J, 4, 4] and drawn
// by fskin's mesh rasteriser (export/render.h: 3 x 3 samples per pixel, the
// 8-bit colours interpolated across faces, unlit) over a uniform background:
// rgb [H, W, 3] in [0, 1], as a player without lights shows the file.
torch::Tensor render_baked_mesh(const RiggedMesh& baked, const torch::Tensor& bones, const PinholeCamera& camera,
                                const std::array<double, 3>& background);

// baked_gaussian_mesh as a skinned glTF (export/skinned_gltf.h) at path
// (.glb / .gltf, else an error naming path), animated by file.bones
// [T, J, 4, 4] canonical -> posed (undefined: no animation) at file.fps with
// file.influences per vertex: what `fskin avatar export RUN --mesh` and
// Python's export_avatar(..., mesh=True) write. Returns the vertices written.
int64_t write_gaussian_mesh_file(const std::string& path, GaussianAvatarImpl& avatar, const RiggedMesh& character,
                                 const GaussianExportOptions& file, const GaussianBakingOptions& options = {});

}  // namespace fskin
