#pragma once
// Deformers map posed points x' to all their canonical correspondences x*
// (roots of d(x) = sum_j w_j(x) B_j x = x', SNARF eq. 5-8) and canonical points
// to posed ones (plain LBS). The roots carry implicit gradients (SNARF eq.
// 12-14 / Fast-SNARF eq. 16-17) w.r.t. the skinning field, the bones and x'.
#include <torch/torch.h>

#include <memory>
#include <optional>

#include "fskin/deformers/start_bones.h"
#include "fskin/fields/skinning_field.h"
#include "fskin/ops/broyden_search.h"

namespace fskin {

enum class GradientMode {
  Exact,        // J^-1 from the true Jacobian at the root (SNARF eq. 14)
  Approximate,  // Broyden's last inverse Jacobian (Fast-SNARF eq. 17)
};

struct DeformerOptions {
  StartBones start_bones;
  int max_iterations = 10;
  double converge_sq = 1e-8;  // squared residual norms
  double diverge_sq = 0.25;
  double denominator_eps = 0;  // SNARF's +-1e-6 on Broyden's denominator
  bool final_step = true;      // one more quasi-Newton step on convergence (fskin's; the papers' code: none)
  GradientMode gradient = GradientMode::Approximate;
  // Roots outside this canonical box are invalid. Fast-SNARF's search confines
  // them to its grid's box by construction; SNARF's MLP has no box (nullopt).
  std::optional<VoxelBox> root_box;
  bool remove_duplicates = true;
  double duplicate_distance = 1e-4;
  int64_t chunk_points = 1 << 18;  // posed points per chunk (bounds temporary memory)

  // The reference settings of each paper, for a character about
  // kReferenceCharacterSize (1.7 m) along its longest side.
  static DeformerOptions snarf();       // 50 iterations, |r| < 1e-5, |r| > 1, exact gradient, no final step
  static DeformerOptions fast_snarf();  // 10 iterations, |r|^2 < 1e-8, |r|^2 > 0.25, approximate

  // The same options with every length multiplied by `length_unit`
  // (character_size.h): the residual thresholds (squared: by its square) and
  // the duplicate distance. Broyden's steps and Jacobians have no unit, so a
  // character scaled by s then takes exactly the steps it takes unscaled.
  DeformerOptions scaled(double length_unit) const;
};

struct DeformerStats {
  int64_t points = 0;           // posed points (all frames)
  int64_t candidates = 0;       // points x slots
  double mean_valid = 0;        // valid distinct roots per point
  double mean_iterations = 0;   // Broyden steps per (point, start)
  double precompute_seconds = 0, search_seconds = 0, filter_seconds = 0, gradient_seconds = 0;
};

struct DeformerOutput {
  torch::Tensor x_canonical;  // [B, N, I, 3], zero where invalid
  torch::Tensor valid;        // [B, N, I] bool
  DeformerStats stats;
};

class Deformer {
 public:
  explicit Deformer(DeformerOptions options);
  virtual ~Deformer() = default;

  // x_posed [B, N, 3], bones [B, J, 4, 4] (canonical -> posed).
  DeformerOutput forward(const torch::Tensor& x_posed, const torch::Tensor& bones);
  // Canonical points [B, N, 3] -> posed [B, N, 3] by LBS with the field's weights.
  // Without gradients (meshing, re-posing) through the prepared pose: for
  // Fast-SNARF the bones blended per voxel once (eq. 15) and 12 channels
  // interpolated per point (eq. 14) instead of J weights, the same LBS since
  // trilinear interpolation is linear. With gradients: weights per point.
  torch::Tensor deform(const torch::Tensor& x_canonical, const torch::Tensor& bones);

  virtual SkinningField& field() = 0;
  const DeformerOptions& options() const { return options_; }
  DeformerOptions& options() { return options_; }

 protected:
  struct SearchResult {
    torch::Tensor x;                 // [B, n, I, 3]
    torch::Tensor valid;             // [B, n, I] bool
    torch::Tensor iterations;        // [B, n, I]
    torch::Tensor inverse_jacobian;  // [B, n, I, 3, 3] when asked for
  };
  // Per-pose preparation (Fast-SNARF: the blended-transform grid, eq. 15).
  virtual void prepare(const torch::Tensor& bones) = 0;
  virtual SearchResult search(const torch::Tensor& x_posed, const torch::Tensor& start_inverses,
                              bool need_inverse_jacobian) = 0;
  // d(x) = T(x) x for frame b of the prepared pose; x [M, 3] -> [M, 3], differentiable.
  virtual torch::Tensor deform_prepared(int64_t b, const torch::Tensor& x) = 0;
  virtual void release() = 0;

  // Jacobian dd/dx at x [M, 3] of frame b -> [M, 3, 3], by autograd.
  torch::Tensor spatial_jacobian(int64_t b, const torch::Tensor& x);
  // The solver's settings from options(): iterations, thresholds, denominator, final step.
  BroydenSearchOptions search_options() const;
  DeformerOptions options_;

 private:
  torch::Tensor attach_gradients(const SearchResult& found, const torch::Tensor& x_posed);
  // The start bones' indices on `device` (cached).
  const torch::Tensor& candidate_index(int64_t num_bones, const torch::Device& device);
  std::vector<int64_t> candidates_;
  torch::Tensor candidate_index_;
};

}  // namespace fskin
