#include "fskin/geometry/mise.h"

#include <fmt/format.h>
#include <torch/torch.h>

#include <chrono>
#include <cmath>

#include "fskin/core/error.h"

namespace fskin {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Every `stride`-th sample along each axis: the samples of one level (a view).
torch::Tensor level_view(const torch::Tensor& grid, int64_t stride) {
  return grid.slice(0, 0, grid.size(0), stride).slice(1, 0, grid.size(1), stride).slice(2, 0, grid.size(2), stride);
}

// Every (k, j, i) in [0, nk) x [0, nj) x [0, ni) as [nk nj ni, 3] int64, k slowest.
torch::Tensor grid_indices(int64_t nk, int64_t nj, int64_t ni) {
  const auto grids = torch::meshgrid({torch::arange(nk, torch::kInt64), torch::arange(nj, torch::kInt64),
                                      torch::arange(ni, torch::kInt64)},
                                     "ij");
  return torch::stack({grids[0].flatten(), grids[1].flatten(), grids[2].flatten()}, 1);
}

// Cells (k, j, i) [M, 3] of a level whose cells span `size` final-grid steps ->
// flat final-grid index of their corner `corner` (bit 0: +i, 1: +j, 2: +k).
torch::Tensor corner_index(const torch::Tensor& cells, int64_t corner, int64_t size, int64_t H, int64_t W) {
  const int64_t di = corner & 1, dj = (corner >> 1) & 1, dk = (corner >> 2) & 1;
  return ((cells.select(1, 0) + dk) * size * H + (cells.select(1, 1) + dj) * size) * W +
         (cells.select(1, 2) + di) * size;
}

}  // namespace

std::string MiseStats::summary() const {
  std::string levels;
  for (size_t l = 0; l < evaluated_per_level.size(); ++l)
    levels += fmt::format("{}{}", l ? " + " : "", evaluated_per_level[l]);
  return fmt::format("MISE on a {}x{}x{} grid: {} of {} samples evaluated ({:.1f} %; per level {}), {} more "
                     "placing the vertices, field {:.2f} s, total {:.2f} s",
                     dims[2], dims[1], dims[0], points_evaluated, dense_points, 100.0 * evaluated_fraction(), levels,
                     refinement_points, field_seconds, seconds);
}

MiseOptions MiseOptions::resolutions(int64_t initial, int64_t final) {
  FSKIN_CHECK(initial >= 1 && final >= initial,
              "MISE: the final resolution ({}) must be at least the initial one ({}) and both positive", final,
              initial);
  MiseOptions options;
  options.initial_resolution = initial;
  options.upsampling_steps = 0;
  while ((initial << options.upsampling_steps) < final) ++options.upsampling_steps;
  FSKIN_CHECK((initial << options.upsampling_steps) == final,
              "MISE: the final resolution ({}) must be the initial one ({}) times a power of two", final, initial);
  return options;
}

void MiseOptions::validate() const {
  FSKIN_CHECK(initial_resolution >= 1, "MISE: initial resolution must be >= 1, got {}", initial_resolution);
  FSKIN_CHECK(upsampling_steps >= 0 && upsampling_steps <= 12, "MISE: upsampling steps must be in [0, 12], got {}",
              upsampling_steps);
  FSKIN_CHECK(final_resolution() <= 4096, "MISE: final resolution {} is above 4096", final_resolution());
  FSKIN_CHECK(dilated_levels >= 0, "MISE: dilated levels must be >= 0, got {}", dilated_levels);
  FSKIN_CHECK(refinement_steps >= 0 && refinement_steps <= 64, "MISE: refinement steps must be in [0, 64], got {}",
              refinement_steps);
  FSKIN_CHECK(batch_size >= 1, "MISE: batch size must be >= 1, got {}", batch_size);
  FSKIN_CHECK(std::isfinite(iso), "MISE: iso value must be finite");
}

MiseResult mise(const ScalarField& field, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                const MiseOptions& options, const MiseProgress& progress) {
  options.validate();
  const auto start = Clock::now();
  double longest = 0;
  for (int axis = 0; axis < 3; ++axis) {
    FSKIN_CHECK(std::isfinite(lo[axis]) && std::isfinite(hi[axis]) && lo[axis] < hi[axis],
                "MISE: box [{}, {}] along axis {} is empty or not finite", lo[axis], hi[axis], axis);
    longest = std::max(longest, hi[axis] - lo[axis]);
  }
  const int64_t steps = options.upsampling_steps, top = int64_t{1} << steps;
  const double coarse = longest / static_cast<double>(options.initial_resolution);
  MiseResult result;
  std::array<int64_t, 3> cells{};  // coarse cells along x, y, z
  for (int axis = 0; axis < 3; ++axis) {
    cells[axis] = std::max<int64_t>(1, static_cast<int64_t>(std::ceil((hi[axis] - lo[axis]) / coarse - 1e-6)));
    result.box.voxel_size[axis] = coarse / static_cast<double>(top);
    result.box.origin[axis] = 0.5 * (lo[axis] + hi[axis]) - 0.5 * coarse * static_cast<double>(cells[axis]);
  }
  auto& stats = result.stats;
  stats.dims = {cells[2] * top + 1, cells[1] * top + 1, cells[0] * top + 1};
  const int64_t D = stats.dims[0], H = stats.dims[1], W = stats.dims[2];
  stats.dense_points = D * H * W;
  auto values = torch::zeros({D, H, W}, torch::kFloat32);
  auto evaluated = torch::zeros({D, H, W}, torch::kBool);
  auto flat_values = values.view({-1}), flat_evaluated = evaluated.view({-1});
  const auto& box = result.box;
  const float iso = static_cast<float>(options.iso);
  const auto inside = [&](const torch::Tensor& v) { return options.inside_above ? v > iso : v < iso; };

  // The field at the final-grid samples with flat indices `index` (distinct,
  // not yet evaluated); points computed as sample_grid computes them.
  const auto evaluate = [&](const torch::Tensor& index) {
    const int64_t M = index.size(0);
    for (int64_t begin = 0; begin < M; begin += options.batch_size) {
      const auto flat = index.narrow(0, begin, std::min(options.batch_size, M - begin));
      const auto k = flat.div(H * W, "floor"), j = flat.div(W, "floor").remainder(H), i = flat.remainder(W);
      const auto points = torch::stack({i.to(torch::kFloat64) * box.voxel_size[0] + box.origin[0],
                                        j.to(torch::kFloat64) * box.voxel_size[1] + box.origin[1],
                                        k.to(torch::kFloat64) * box.voxel_size[2] + box.origin[2]},
                                       1)
                              .to(torch::kFloat32);
      const auto field_start = Clock::now();
      const auto v = field(points);
      stats.field_seconds += seconds_since(field_start);
      FSKIN_CHECK(v.defined() && v.numel() == flat.size(0), "MISE: the field returned {} values for {} points",
                  v.defined() ? v.numel() : 0, flat.size(0));
      flat_values.index_put_({flat}, v.reshape({-1}).to(torch::kCPU, torch::kFloat32));
      flat_evaluated.index_put_({flat}, torch::ones({flat.size(0)}, torch::kBool));
    }
    stats.evaluated_per_level.push_back(M);
    stats.points_evaluated += M;
  };

  // Level 0: every coarse sample; every coarse cell is a candidate.
  const auto coarse_samples = grid_indices(cells[2] + 1, cells[1] + 1, cells[0] + 1) * top;
  evaluate((coarse_samples.select(1, 0) * H + coarse_samples.select(1, 1)) * W + coarse_samples.select(1, 2));
  if (progress) progress(0, steps + 1, stats.points_evaluated);
  std::array<int64_t, 3> level_cells = {cells[2], cells[1], cells[0]};  // cells along z, y, x at this level
  auto candidates = grid_indices(level_cells[0], level_cells[1], level_cells[2]);  // [M, 3] (k, j, i)
  const auto ring = grid_indices(3, 3, 3) - 1, children = grid_indices(2, 2, 2), samples = grid_indices(3, 3, 3);
  for (int64_t level = 0; level < steps; ++level) {
    const int64_t size = top >> level;  // final-grid steps per cell of this level
    // Active cells: candidates whose corners lie on both sides of the iso level ...
    auto any = torch::zeros({candidates.size(0)}, torch::kBool), all = torch::ones({candidates.size(0)}, torch::kBool);
    for (int corner = 0; corner < 8; ++corner) {
      const auto in = inside(flat_values.index_select(0, corner_index(candidates, corner, size, H, W)));
      any |= in;
      all &= in;
    }
    auto active = candidates.index_select(0, (any & ~all).nonzero().squeeze(1));
    // ... and, on the coarsest levels, their 26 neighbours.
    if (level < options.dilated_levels && active.size(0) > 0) {
      const auto around = (active.unsqueeze(1) + ring.unsqueeze(0)).reshape({-1, 3});
      const auto bound = torch::tensor({level_cells[0], level_cells[1], level_cells[2]}, torch::kInt64);
      const auto in_grid = ((around >= 0) & (around < bound)).all(1);
      const auto kept = around.index_select(0, in_grid.nonzero().squeeze(1));
      auto mask = torch::zeros({level_cells[0] * level_cells[1] * level_cells[2]}, torch::kBool);
      mask.index_put_({(kept.select(1, 0) * level_cells[1] + kept.select(1, 1)) * level_cells[2] + kept.select(1, 2)},
                      torch::ones({kept.size(0)}, torch::kBool));
      const auto flat = mask.nonzero().squeeze(1);  // sorted: deterministic order
      active = torch::stack({flat.div(level_cells[1] * level_cells[2], "floor"),
                             flat.div(level_cells[2], "floor").remainder(level_cells[1]),
                             flat.remainder(level_cells[2])},
                            1);
    }
    // Split them: the 27 samples of each at half the spacing, those not yet evaluated.
    const int64_t half = size / 2;
    const auto fine = (2 * active).unsqueeze(1) + samples.unsqueeze(0);  // [M, 27, 3] in half-size units
    auto index = ((fine.select(2, 0) * half * H + fine.select(2, 1) * half) * W + fine.select(2, 2) * half).flatten();
    index = index.index_select(0, (~flat_evaluated.index_select(0, index)).nonzero().squeeze(1));
    index = std::get<0>(torch::unique_consecutive(std::get<0>(index.sort())));
    evaluate(index);
    if (progress) progress(level + 1, steps + 1, stats.points_evaluated);
    candidates = ((2 * active).unsqueeze(1) + children.unsqueeze(0)).reshape({-1, 3});
    for (auto& n : level_cells) n *= 2;
  }
  // Samples never evaluated take the trilinear interpolation of the level
  // above, coarse to fine (align-corners: fine sample 2m sits on coarse sample m).
  namespace F = torch::nn::functional;
  for (int64_t level = 1; level <= steps; ++level) {
    const int64_t stride = top >> level;
    auto view = level_view(values, stride);
    const auto up = F::interpolate(level_view(values, 2 * stride).contiguous().unsqueeze(0).unsqueeze(0),
                                   F::InterpolateFuncOptions()
                                       .size(std::vector<int64_t>{view.size(0), view.size(1), view.size(2)})
                                       .mode(torch::kTrilinear)
                                       .align_corners(true))
                        .squeeze(0)
                        .squeeze(0);
    view.copy_(torch::where(level_view(evaluated, stride), view, up));
  }
  result.mesh = iso_surface(values, box, IsoSurfaceOptions{options.iso, options.inside_above});
  if (options.refinement_steps > 0) {
    const auto field_start = Clock::now();
    stats.refinement_points =
        refine_iso_vertices(result.mesh, values, box, field, options.iso, options.refinement_steps, options.batch_size)
            .field_points;
    stats.field_seconds += seconds_since(field_start);
  }
  result.values = values;
  stats.seconds = seconds_since(start);
  return result;
}

}  // namespace fskin
