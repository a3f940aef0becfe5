#pragma once
// Multi-resolution iso-surface extraction (MISE, Occupancy Networks sec. 3.3):
// the field is sampled on a coarse grid; every cell whose corners lie on both
// sides of the iso level is active and is split into 2 x 2 x 2 cells, of
// which only the new samples are evaluated; the children's corners decide
// the next level, and so on down to the final resolution, where marching
// cubes (iso_surface) runs. Samples never evaluated take the trilinear
// interpolation of the level above, so away from the surface the final grid
// holds coarse values of the right sign. On the coarsest levels (options) the
// neighbours of active cells are split too, so a thin part that crosses a
// coarse cell between its corners is not lost.
//
// Cost: O(surface area / h^2) field evaluations at final spacing h instead of
// O(volume / h^3). What MISE cannot find is a part that no coarse sample
// falls into: pick the initial resolution so coarse cells are smaller than
// the thinnest part.
#include <torch/types.h>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "fskin/geometry/iso_refinement.h"
#include "fskin/geometry/iso_surface.h"
#include "fskin/geometry/mesh.h"

namespace fskin {

struct MiseOptions {
  // Cells along the longest side of the box at the coarsest level; the other
  // sides get as many cells of the same size as they need (cubic voxels).
  int64_t initial_resolution = 32;
  // Refinements; the final grid has initial_resolution * 2^steps cells along
  // the longest side (ONet: 32 -> 256 in 3 steps).
  int64_t upsampling_steps = 3;
  // On this many of the coarsest levels, the cells next to an active cell are
  // split too (ONet: 0). The coarse levels are where a thin part can cross a
  // cell without any corner inside it; one level costs little.
  int64_t dilated_levels = 1;
  // Field evaluations per vertex that move the final mesh's vertices onto the
  // level set along their grid edges (geometry/iso_refinement.h); 0 keeps
  // marching cubes' linear interpolation, which terraces the surfaces of
  // nearly binary fields such as learned occupancies.
  int64_t refinement_steps = 0;
  double iso = 0.0;          // logit 0 = probability 0.5
  bool inside_above = true;  // as IsoSurfaceOptions
  int64_t batch_size = 1 << 16;  // points per field call

  // The options going from `initial` to `final` cells along the longest side;
  // throws fskin::Error unless final / initial is a power of two.
  static MiseOptions resolutions(int64_t initial, int64_t final);
  int64_t final_resolution() const { return initial_resolution << upsampling_steps; }
  void validate() const;
};

struct MiseStats {
  std::array<int64_t, 3> dims{};        // final grid samples {D, H, W}
  int64_t points_evaluated = 0;         // field evaluations, all levels
  int64_t dense_points = 0;             // D * H * W: what sampling the final grid costs
  std::vector<int64_t> evaluated_per_level;  // level 0 = the coarse grid
  int64_t refinement_points = 0;        // field evaluations that moved vertices onto the level set
  double field_seconds = 0;             // inside the field callback
  double seconds = 0;                   // everything, marching cubes included
  double evaluated_fraction() const {
    return dense_points > 0 ? static_cast<double>(points_evaluated) / static_cast<double>(dense_points) : 0.0;
  }
  // One line: grid, samples evaluated against dense, seconds.
  std::string summary() const;
};

struct MiseResult {
  Mesh mesh;
  GridBox box;           // the final grid (covers [lo, hi], centred on it)
  torch::Tensor values;  // [D, H, W] float32: evaluated or interpolated samples
  MiseStats stats;
};

// Called after each level with (level, levels, points evaluated so far).
using MiseProgress = std::function<void(int64_t level, int64_t levels, int64_t points_evaluated)>;

// The iso-surface of `field` in the box [lo, hi] (x, y, z; lo < hi). The grid
// has cubic voxels and covers the box, centred on it. Deterministic.
MiseResult mise(const ScalarField& field, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                const MiseOptions& options = {}, const MiseProgress& progress = {});

}  // namespace fskin
