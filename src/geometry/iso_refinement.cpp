#include "fskin/geometry/iso_refinement.h"

#include <torch/torch.h>

#include <cmath>
#include <vector>

#include "fskin/core/error.h"

namespace fskin {

IsoRefinementStats refine_iso_vertices(Mesh& mesh, const torch::Tensor& values, const GridBox& box,
                                       const ScalarField& field, double iso, int64_t steps, int64_t batch_size) {
  FSKIN_CHECK(steps >= 0 && batch_size >= 1, "iso refinement: steps {} and batch size {} out of range", steps,
              batch_size);
  FSKIN_CHECK(values.dim() == 3, "iso refinement: values must be [D, H, W]");
  IsoRefinementStats stats;
  const int64_t V = mesh.num_vertices();
  if (steps == 0 || V == 0) return stats;
  const auto grid = values.to(torch::kCPU, torch::kFloat64).contiguous();
  const double* g = grid.data_ptr<double>();
  const int64_t D = grid.size(0), H = grid.size(1), W = grid.size(2);
  const int64_t dims[3] = {W, H, D};  // samples along x, y, z
  auto vertices = mesh.vertices.to(torch::kFloat64).contiguous();
  double* vp = vertices.data_ptr<double>();

  // Per moved vertex: its edge's ends a, b (world) and the field there, relative to iso.
  struct Bracket {
    int64_t vertex;
    double a[3], b[3];
    double fa, fb;
    int last_side = 0;  // which end moved last (Illinois: halve the other end's value when one end keeps moving)
  };
  std::vector<Bracket> brackets;
  brackets.reserve(V);
  for (int64_t v = 0; v < V; ++v) {
    // Grid coordinates: integral along two axes, fractional along the edge's.
    // The edge's axis is the one farthest from a sample; the other two are
    // integral up to the rounding of the mesh's float32 vertices, which grows
    // with their distance from the origin (thousandths of a cell for a body
    // a few units from it on a 256 grid), so they are only required to be
    // nearer a sample than a quarter cell.
    double coordinate[3], off_sample[3];
    int edge_axis = 0;
    for (int axis = 0; axis < 3; ++axis) {
      coordinate[axis] = (vp[3 * v + axis] - box.origin[axis]) / box.voxel_size[axis];
      off_sample[axis] = std::abs(coordinate[axis] - std::round(coordinate[axis]));
      if (off_sample[axis] > off_sample[edge_axis]) edge_axis = axis;
    }
    bool on_an_edge = true;
    for (int axis = 0; axis < 3; ++axis)
      if (axis != edge_axis && off_sample[axis] > 0.25) on_an_edge = false;
    if (!on_an_edge) continue;  // not a vertex of this grid: keep it
    int64_t lower[3], upper[3];
    for (int axis = 0; axis < 3; ++axis) {
      lower[axis] = upper[axis] = static_cast<int64_t>(std::llround(coordinate[axis]));
    }
    lower[edge_axis] = static_cast<int64_t>(std::floor(coordinate[edge_axis]));
    upper[edge_axis] = lower[edge_axis] + 1;
    bool inside = true;
    for (int axis = 0; axis < 3; ++axis)
      if (lower[axis] < 0 || upper[axis] >= dims[axis]) inside = false;
    if (!inside) continue;
    const auto sample = [&](const int64_t* s) { return g[(s[2] * H + s[1]) * W + s[0]] - iso; };
    Bracket bracket{v, {}, {}, sample(lower), sample(upper)};
    if (!(bracket.fa * bracket.fb < 0)) continue;
    for (int axis = 0; axis < 3; ++axis) {
      bracket.a[axis] = box.origin[axis] + static_cast<double>(lower[axis]) * box.voxel_size[axis];
      bracket.b[axis] = box.origin[axis] + static_cast<double>(upper[axis]) * box.voxel_size[axis];
    }
    brackets.push_back(bracket);
  }
  stats.vertices_moved = static_cast<int64_t>(brackets.size());
  const auto crossing = [](const Bracket& r, double* out) {
    const double t = r.fa / (r.fa - r.fb);
    for (int axis = 0; axis < 3; ++axis) out[axis] = r.a[axis] + t * (r.b[axis] - r.a[axis]);
  };
  const int64_t M = stats.vertices_moved;
  for (int64_t step = 0; step < steps && M > 0; ++step) {
    auto points = torch::empty({M, 3}, torch::kFloat64);
    double* pp = points.data_ptr<double>();
    for (int64_t m = 0; m < M; ++m) crossing(brackets[m], pp + 3 * m);
    auto points32 = points.to(torch::kFloat32);
    for (int64_t begin = 0; begin < M; begin += batch_size) {
      const int64_t n = std::min(batch_size, M - begin);
      const auto f = field(points32.narrow(0, begin, n));
      FSKIN_CHECK(f.defined() && f.numel() == n, "iso refinement: the field returned {} values for {} points",
                  f.defined() ? f.numel() : 0, n);
      const auto fv = f.reshape({-1}).to(torch::kCPU, torch::kFloat64).contiguous();
      const double* fp = fv.data_ptr<double>();
      for (int64_t k = 0; k < n; ++k) {
        auto& r = brackets[begin + k];
        const double value = fp[k] - iso;
        const double* p = pp + 3 * (begin + k);
        if (!std::isfinite(value) || value == 0) {
          // Found (or the field failed here): collapse the bracket onto the point.
          for (int axis = 0; axis < 3; ++axis) r.a[axis] = r.b[axis] = p[axis];
          continue;
        }
        if ((value < 0) == (r.fa < 0)) {
          for (int axis = 0; axis < 3; ++axis) r.a[axis] = p[axis];
          r.fa = value;
          if (r.last_side == -1) r.fb *= 0.5;
          r.last_side = -1;
        } else {
          for (int axis = 0; axis < 3; ++axis) r.b[axis] = p[axis];
          r.fb = value;
          if (r.last_side == 1) r.fa *= 0.5;
          r.last_side = 1;
        }
      }
    }
    stats.field_points += M;
  }
  for (const auto& r : brackets) {
    if (r.a[0] == r.b[0] && r.a[1] == r.b[1] && r.a[2] == r.b[2]) {
      for (int axis = 0; axis < 3; ++axis) vp[3 * r.vertex + axis] = r.a[axis];
    } else {
      crossing(r, vp + 3 * r.vertex);
    }
  }
  mesh.vertices = vertices.to(torch::kFloat32);
  return stats;
}

}  // namespace fskin
