#pragma once
// An animatable avatar of articulated 3-D Gaussians (issue 37; the idea of
// 3DGS-Avatar, GART and GauHuman, for any skeleton): canonical Gaussians
// (mean, scale, rotation, opacity, colour as spherical harmonics) posed by
// forward linear blend skinning, no root finding. A Gaussian's skinning
// weights come from one of two sources (`skinning_source`):
//  - "surface": its own, the character's vertex weights interpolated at the
//    mesh point it was sampled on (barycentric), carried by the Gaussians that
//    clone or split from it: the rig's weights exactly where the surface is,
//    and no field to read per step (GaussianAvatar and SplattingAvatar embed
//    their Gaussians on the template mesh likewise);
//  - "grid": the character's weights diffused into a voxel grid
//    (fields/preset_skinning_field.h, as the volume avatar uses) read at the
//    Gaussian's current canonical mean, so a Gaussian takes the weights of
//    where it moves (3DGS-Avatar, GART).
// With `learned_skinning`, each Gaussian also learns a correction of its
// weights' logits, w = softmax(log(w_source) + delta), delta starting at zero
// (GART's learned correction of the rig's weights, per Gaussian instead of
// per voxel), for what the rig's weights do not move as the images do.
// With T = sum_j w_j B_j (SNARF eq. 4) and A its 3 x 3 part:
//   mean' = T mean,  Sigma' = A Sigma A^T
// (the exact image of the Gaussian under the affine map T; A is a rotation
// where one bone dominates). Spherical harmonics are evaluated in canonical
// space, at the view direction mapped back by A^T.
#include <torch/torch.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/gaussians/gaussian_appearance.h"
#include "fskin/gaussians/gaussian_shading.h"
#include "fskin/gaussians/non_rigid_offset.h"
#include "fskin/geometry/pinhole_camera.h"
#include "fskin/skeleton/rigged_mesh.h"

namespace fskin {

struct GaussianAvatarOptions {
  int64_t initial_gaussians = 20000;  // area-uniform on the canonical mesh
  int64_t sh_degree = 1;              // 0-3
  double initial_opacity = 0.5;
  // Thickness along the face normal relative to the width at the start: 1,
  // spheres; below 1, discs in the faces' planes. Discs: a sphere's half
  // outside the surface widens the silhouette from every camera whose
  // outline it does not lie on, which few training views correct.
  double initial_thickness = 0.03;
  // Each Gaussian keeps the mesh point it was sampled on and that face's
  // normal (surface_anchors; its clones and splits inherit them), for priors
  // on where it lies against the surface (gaussians/surface_layer.h). Set by
  // the training from its prior's weight (GaussianTrainOptions::avatar_options),
  // not a config key of its own: a checkpoint holds the anchors exactly when
  // its run has the prior.
  bool anchored = false;
  std::string skinning_source = "surface";  // "surface" | "grid" (above)
  int64_t skinning_grid_resolution = 64;     // "grid": voxels along the canonical box's longest side
  bool learned_skinning = false;             // learn a per-Gaussian correction of the weights (above)
  // Opacities scaled by the projection's compensation of its dilation
  // (gaussian_projection.h): footprints keep their weight from any distance.
  bool antialiased = true;
  // The screen-space dilation added to every projected footprint, pixels^2
  // (gaussian_projection.h). 0.1, Mip-Splatting's 2-D filter (with the
  // compensation above), rather than 3DGS's 0.3: the wider blur softens
  // detail finer than a few pixels and the thin parts of a small picture
  // (docs/benchmarks.md, "Gaussian avatars").
  double dilation = 0.1;
  // A pose-conditioned offset of the means before skinning
  // (gaussians/non_rigid_offset.h); off: the Gaussians move rigidly with
  // their blended bones.
  bool non_rigid = false;
  NonRigidOffsetOptions non_rigid_network;
  // "none": the colour is the spherical harmonics' alone; "irradiance": times
  // a learned shade of the posed normal (gaussian_shading.h: lights that stay
  // where they are while the body moves).
  std::string shading = "none";
  // Per-frame appearance codes' network (gaussians/gaussian_appearance.h);
  // dim 0: none. The codes themselves belong to the training frames and live
  // with the run (GaussianTrainable, radiance/appearance_codes.h).
  GaussianAppearanceOptions appearance;
  void validate() const;
};

// Gaussians in a frame's posed space.
struct PosedGaussians {
  torch::Tensor offsets;      // [N, 3] the non-rigid offsets in canonical space; undefined without
  torch::Tensor means;        // [N, 3]
  torch::Tensor covariances;  // [N, 3, 3]
  torch::Tensor linear;       // [N, 3, 3] A, the blended transforms' 3 x 3 part
  torch::Tensor opacities;    // [N] in (0, 1)
};

struct GaussianRender {
  torch::Tensor image;    // [H, W, 3]
  torch::Tensor alpha;    // [H, W]
  torch::Tensor means2d;  // [N, 2] the projected means (density control reads their gradient)
  torch::Tensor radii;    // [N] pixels, 0 where not drawn
  torch::Tensor offsets;  // [N, 3] the non-rigid offsets (their prior reads them); undefined without
};

// The middle of the box of posed means [N, 3] (a turntable and the unseen-view
// prior turn the camera about it).
Eigen::Vector3d posed_centre(const torch::Tensor& means);

class GaussianAvatarImpl : public torch::nn::Module {
 public:
  // Gaussians sampled on character's canonical mesh (deterministic in `seed`):
  // isotropic, as wide as the samples' mean spacing, grey.
  GaussianAvatarImpl(const RiggedMesh& character, GaussianAvatarOptions options, uint64_t seed);

  int64_t size() const { return means_.size(0); }
  // The initial Gaussians' width: the mean spacing of N area-uniform samples,
  // sqrt(surface area / N) (a function of the mesh and N alone).
  double initial_spacing() const { return initial_spacing_; }
  int64_t sh_degree() const { return options_.sh_degree; }
  const GaussianAvatarOptions& options() const { return options_; }

  // Canonical parameters (leaf tensors, registered with the module):
  // means [N, 3]; log_scales [N, 3] (log standard deviations); rotations
  // [N, 4] (quaternions (w, x, y, z), unnormalised); opacity_logits [N];
  // spherical harmonics (spherical_harmonics.h), degree 0 and the rest apart
  // since they train at different rates (3DGS's features_dc / features_rest):
  // sh_dc [N, 1, 3], sh_rest [N, (degree + 1)^2 - 1, 3].
  torch::Tensor& means() { return means_; }
  torch::Tensor& log_scales() { return log_scales_; }
  torch::Tensor& rotations() { return rotations_; }
  torch::Tensor& opacity_logits() { return opacity_logits_; }
  torch::Tensor& sh_dc() { return sh_dc_; }
  torch::Tensor& sh_rest() { return sh_rest_; }
  const torch::Tensor& means() const { return means_; }
  const torch::Tensor& log_scales() const { return log_scales_; }
  const torch::Tensor& rotations() const { return rotations_; }
  const torch::Tensor& opacity_logits() const { return opacity_logits_; }
  const torch::Tensor& sh_dc() const { return sh_dc_; }
  const torch::Tensor& sh_rest() const { return sh_rest_; }
  torch::Tensor sh() const;  // both, [N, (degree + 1)^2, 3]
  // sh() without gradients, the appearance network's offset at code zero
  // (the frames' average appearance) folded into degree 0: what exports
  // write, which have no codes. sh() without appearance codes.
  torch::Tensor average_appearance_sh();

  // Skinning weights [N, J] of the Gaussians (rows sum to 1).
  torch::Tensor skinning_weights();
  // The Gaussians in the frame of bones [J, 4, 4] (canonical -> posed).
  PosedGaussians pose(const torch::Tensor& bones);
  // posed_centre of the Gaussians posed by bones [J, 4, 4].
  Eigen::Vector3d centre(const torch::Tensor& bones);
  // A picture of the posed Gaussians [H, W, 3] and its alpha over a uniform
  // background; differentiable in the parameters (and in bones when they
  // require gradients).
  // With appearance codes, `appearance` is the frame's code [dim]
  // (undefined: code zero, the frames' average appearance).
  GaussianRender render(const torch::Tensor& bones, const PinholeCamera& camera,
                        const std::array<double, 3>& background, const torch::Tensor& appearance = {});
  // The same for Gaussians already posed (pose(bones)), so that a step drawing
  // its pose twice or reading its centre poses once.
  GaussianRender render(const PosedGaussians& posed, const PinholeCamera& camera,
                        const std::array<double, 3>& background, const torch::Tensor& appearance = {});

  // The per-Gaussian weights of the "surface" source [N, J] (a buffer, not
  // trained); [N, 0] with the "grid" source. Density control gathers its rows
  // with the parameters'.
  torch::Tensor& surface_weights() { return surface_weights_; }
  // The learned corrections of the weights' logits [N, J] (a parameter,
  // zeros at the start); [N, 0] without learned_skinning.
  torch::Tensor& skinning_corrections() { return skinning_corrections_; }
  const torch::Tensor& surface_weights() const { return surface_weights_; }
  const torch::Tensor& skinning_corrections() const { return skinning_corrections_; }
  // The non-rigid offset's network; empty (nullptr) without options.non_rigid.
  NonRigidOffset& non_rigid_offset() { return non_rigid_; }
  const NonRigidOffset& non_rigid_offset() const { return non_rigid_; }
  // The shading's lighting; empty (nullptr) with shading "none".
  GaussianShading& shading() { return shading_; }
  const GaussianShading& shading() const { return shading_; }
  // The appearance codes' network; empty (nullptr) with appearance.dim 0.
  GaussianAppearance& appearance() { return appearance_; }
  const GaussianAppearance& appearance() const { return appearance_; }

  // [N, 6]: per Gaussian the canonical mesh point it was sampled on and the
  // face's unit normal there; [N, 0] unless options().anchored (a buffer).
  torch::Tensor& surface_anchors() { return surface_anchors_; }
  const torch::Tensor& surface_anchors() const { return surface_anchors_; }
  // [N] each mean's height above its anchor's tangent plane (along the
  // normal; negative: below the surface), differentiable in the means.
  torch::Tensor anchor_heights() const;

  // Module::load, and the unregistered [N, 0] anchors of an avatar without
  // them sized to the loaded Gaussians.
  void load(torch::serialize::InputArchive& archive) override;

  // Replaces every per-Gaussian tensor by a gathered, extended or filtered
  // version (densification and pruning); the tensors must agree in N. The
  // parameters keep their identity (optimisers keep holding them); graphs
  // built on the old ones must be released before the next backward (their
  // gradient accumulators expect the old sizes).
  void replace_gaussians(torch::Tensor means, torch::Tensor log_scales, torch::Tensor rotations,
                         torch::Tensor opacity_logits, torch::Tensor sh_dc, torch::Tensor sh_rest,
                         torch::Tensor surface_weights, torch::Tensor skinning_corrections,
                         torch::Tensor surface_anchors);

 private:
  GaussianAvatarOptions options_;
  int64_t bones_ = 0;
  double initial_spacing_ = 0;
  std::shared_ptr<FrozenSkinningField> skinning_;  // the "grid" source only
  NonRigidOffset non_rigid_{nullptr};
  GaussianShading shading_{nullptr};
  GaussianAppearance appearance_{nullptr};
  torch::Tensor means_, log_scales_, rotations_, opacity_logits_, sh_dc_, sh_rest_, surface_weights_, skinning_corrections_,
      surface_anchors_;
};
TORCH_MODULE(GaussianAvatar);

}  // namespace fskin
