#pragma once
// An animatable avatar from images (Fast-SNARF sec. 7): a canonical radiance
// field (radiance_field.h) seen through the Fast-SNARF deformer with the
// character's skinning weights diffused into a voxel grid (preset weights,
// fields/preset_skinning_field.h). A posed sample x' is mapped to all its
// canonical correspondences, the field is evaluated at each, and the one of
// largest density gives the sample its density and colour (sec. 7); the
// samples are composited along each ray (ops/ray_compositing.h, eq. 18-19).
// Empty space is skipped with occupancy grids (occupancy_grid.h): a canonical
// one refreshed from the field's density, a posed one per frame from it.
//
// Skinning "learned" (Fast-SNARF sec. 7 learns the avatar's skinning; here
// for clothing and hair the rig's weights do not fit): the weight grid is
// softmax(L) over the bones, L a parameter started at the log of the preset
// grid (floored at 1e-3, so that every bone can still win a voxel), and the
// rays' correspondences carry the implicit gradient with respect to the
// grid (Fast-SNARF eq. 16-17), so the renderer's loss trains it;
// skinning_prior() keeps it near the preset weights.
#include <torch/torch.h>

#include <array>
#include <memory>

#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/occupancy_grid.h"
#include "fskin/radiance/radiance_field.h"

namespace fskin {

struct AvatarOptions {
  RadianceFieldOptions field;
  int64_t skinning_grid_resolution = 64;  // voxels along the canonical box's longest side
  std::string skinning = "preset";        // "preset" (the character's weights) or "learned" (above)
  int64_t canonical_grid_resolution = 64;
  int64_t posed_grid_resolution = 48;
  // Samples along the diagonal of a frame's posed box (the step of every ray).
  int64_t samples_per_diagonal = 320;
  int64_t start_bones = 3;  // Broyden starts per sample (the most likely bones)
  // Canonical cells are occupied where sigma * step > this (an opacity of about 0.5 %).
  double occupancy_opacity = 0.005;
  void validate() const;
};

// A frame ready to render: its bones and the posed box and grid.
struct PosedFrame {
  torch::Tensor bones;  // [J, 4, 4] canonical -> posed
  OccupancyGrid grid;   // posed space
  // The box of the grid's occupied cells: rays are clipped to it (empty:
  // lower == upper, no ray takes samples).
  std::array<double, 3> lower{0, 0, 0}, upper{0, 0, 0};
  double step = 0;      // distance between samples along a ray
  // The frame's appearance code (radiance/appearance_codes.h) when the field
  // has codes; undefined: the mean appearance.
  torch::Tensor appearance;
};

struct RayRender {
  torch::Tensor color;    // [R, 3]
  torch::Tensor opacity;  // [R]
  int64_t samples = 0;    // samples in occupied cells (evaluated)
};

class AvatarImpl : public torch::nn::Module {
 public:
  AvatarImpl(const RiggedMesh& character, AvatarOptions options);

  // The posed frame of bones [J, 4, 4] (float32, canonical -> posed).
  PosedFrame pose(const torch::Tensor& bones);
  // Renders rays (origins, unit directions [R, 3]) against background [R, 3]:
  // differentiable in the field's parameters, and in frame.bones when they
  // require gradients (pose refinement, radiance/pose_correction.h). jitter: a random offset of the
  // samples along each ray (training), else the samples sit at fixed steps.
  RayRender render_rays(const PosedFrame& frame, const torch::Tensor& origins, const torch::Tensor& directions,
                        const torch::Tensor& background, bool jitter);
  // A whole picture [H, W, 3] float in [0, 1] and its opacity [H, W], without gradients.
  std::pair<torch::Tensor, torch::Tensor> render_image(const PosedFrame& frame, const PinholeCamera& camera,
                                                       const std::array<double, 3>& background,
                                                       int64_t rays_per_chunk = 16384);
  // Re-marks the canonical occupancy grid from the field's density (at
  // jittered points in each cell), dilated by one cell.
  void update_canonical_occupancy();
  // Every canonical cell occupied (before the field has learned anything).
  void reset_canonical_occupancy();
  // Learned skinning: sets the deformer's grid from the parameter, with its
  // autograd graph when gradients are enabled (training calls it before each
  // step's rays) and detached otherwise (after loading); preset: nothing.
  void refresh_skinning();
  bool learns_skinning() const { return skinning_logits_.defined(); }
  // Learned skinning: the mean over voxels of the squared distance between
  // the deformer's current grid (refresh_skinning) and the preset weights
  // (summed over bones); preset: 0.
  torch::Tensor skinning_prior();

  RadianceField& field() { return field_; }
  // The canonical occupancy grid (a copy of the module's buffer "canonical_occupancy").
  OccupancyGrid canonical_grid() const;
  const AvatarOptions& options() const { return options_; }
  FastSnarfDeformer& deformer() { return *deformer_; }
  std::array<double, 3> canonical_lower() const { return lower_; }
  std::array<double, 3> canonical_upper() const { return upper_; }

 private:
  AvatarOptions options_;
  std::array<double, 3> lower_, upper_;
  std::shared_ptr<GridSkinningField> skinning_;
  std::shared_ptr<CallerGridSkinningField> learned_skinning_;  // learned: the grid the deformer reads
  torch::Tensor preset_grid_;      // [D, H, W, J] the character's weights in the grid
  torch::Tensor skinning_logits_;  // learned: L, a parameter
  std::unique_ptr<FastSnarfDeformer> deformer_;
  RadianceField field_{nullptr};
  torch::Tensor occupancy_;  // [R, R, R] uint8, saved with the module
};
TORCH_MODULE(Avatar);

}  // namespace fskin
