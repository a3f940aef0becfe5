// Marching cubes with a case table that is *built* here rather than copied.
//
// Why hand-written: no Debian package offers a small iso-surfacer (VTK, CGAL and
// OpenVDB are far too heavy for one function), and the classic 256-case tables
// resolve ambiguous cube faces inconsistently, which leaves cracks. Here the
// table is derived from one rule, so it is ambiguity-free by construction:
//   1. On every cube face the crossing edges are joined by segments; on an
//      ambiguous face (two inside corners on a diagonal) the segments always cut
//      off the inside corners. The decision depends only on the face's four
//      signs, so the two cubes sharing a face draw the same segments.
//   2. The segments of a cube form disjoint closed loops (every crossing edge
//      lies on exactly two faces); each loop becomes one disc, oriented so its
//      normal points from the inside corners to the outside ones.
//   3. A loop is triangulated as a fan from an apex whose chords never join two
//      vertices on a common cube face; such a chord is the only edge a
//      neighbouring cube could also create, so every mesh edge is shared by
//      exactly two triangles (once in each direction): a closed, oriented
//      2-manifold.
#include "fskin/geometry/iso_surface.h"

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {
namespace {

// Cube corner c sits at (c & 1, (c >> 1) & 1, (c >> 2) & 1) in (x, y, z).
int corner_bit(int corner, int axis) { return (corner >> axis) & 1; }

struct CubeEdge {
  int from, to, axis;  // `from` is the lower corner (bit `axis` is 0)
};

struct CaseTable {
  std::vector<CubeEdge> edges;                                 // 12
  std::array<std::vector<std::array<int, 3>>, 256> triangles;  // edge ids, CCW from outside
};

CaseTable build_case_table() {
  CaseTable table;
  int edge_of[8][8];
  for (int c = 0; c < 8; ++c)
    for (int axis = 0; axis < 3; ++axis)
      if (corner_bit(c, axis) == 0) {
        const int other = c | (1 << axis);
        edge_of[c][other] = edge_of[other][c] = static_cast<int>(table.edges.size());
        table.edges.push_back({c, other, axis});
      }
  // The four corners of each face in cyclic order.
  std::vector<std::array<int, 4>> faces;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      std::array<int, 4> corners{};
      for (int q = 0; q < 4; ++q) corners[q] = side << axis | uv[q][0] << u | uv[q][1] << v;
      faces.push_back(corners);
    }
  const auto midpoint = [&](int e, int axis) {
    return 0.5 * (corner_bit(table.edges[e].from, axis) + corner_bit(table.edges[e].to, axis));
  };
  const auto share_face = [&](int e1, int e2) {
    const int corners[4] = {table.edges[e1].from, table.edges[e1].to, table.edges[e2].from,
                            table.edges[e2].to};
    for (int axis = 0; axis < 3; ++axis) {
      int bit = corner_bit(corners[0], axis), same = 1;
      for (int c = 1; c < 4; ++c) same &= corner_bit(corners[c], axis) == bit;
      if (same) return true;
    }
    return false;
  };

  for (int mask = 0; mask < 256; ++mask) {
    const auto inside = [&](int corner) { return (mask >> corner) & 1; };
    std::vector<std::vector<int>> neighbours(12);
    for (const auto& q : faces) {
      int face_edges[4];
      bool crossing[4];
      for (int k = 0; k < 4; ++k) {
        face_edges[k] = edge_of[q[k]][q[(k + 1) % 4]];
        crossing[k] = inside(q[k]) != inside(q[(k + 1) % 4]);
      }
      const auto join = [&](int a, int b) {
        neighbours[face_edges[a]].push_back(face_edges[b]);
        neighbours[face_edges[b]].push_back(face_edges[a]);
      };
      const int count = crossing[0] + crossing[1] + crossing[2] + crossing[3];
      if (count == 2) {
        int a = -1, b = -1;
        for (int k = 0; k < 4; ++k)
          if (crossing[k]) (a < 0 ? a : b) = k;
        join(a, b);
      } else if (count == 4) {  // ambiguous: cut off each inside corner
        for (int k = 0; k < 4; ++k)
          if (inside(q[k])) join((k + 3) % 4, k);
      }
    }
    std::vector<bool> visited(12, false);
    for (int start = 0; start < 12; ++start) {
      if (neighbours[start].empty() || visited[start]) continue;
      std::vector<int> loop;
      for (int previous = -1, e = start; !visited[e];) {
        visited[e] = true;
        loop.push_back(e);
        const int next = neighbours[e][0] != previous ? neighbours[e][0] : neighbours[e][1];
        previous = e;
        e = next;
      }
      // Orientation: Newell normal of the loop through the edge midpoints
      // against the inside -> outside direction of its edges.
      double normal[3] = {0, 0, 0}, outward[3] = {0, 0, 0};
      const int n = static_cast<int>(loop.size());
      for (int i = 0; i < n; ++i) {
        const int a = loop[i], b = loop[(i + 1) % n];
        for (int axis = 0; axis < 3; ++axis) {
          const int u = (axis + 1) % 3, v = (axis + 2) % 3;
          normal[axis] += (midpoint(a, u) - midpoint(b, u)) * (midpoint(a, v) + midpoint(b, v));
        }
        const auto& edge = table.edges[a];
        outward[edge.axis] += inside(edge.from) ? 1.0 : -1.0;
      }
      const double dot = normal[0] * outward[0] + normal[1] * outward[1] + normal[2] * outward[2];
      FSKIN_CHECK(dot != 0.0, "iso_surface: degenerate loop in case {}", mask);
      if (dot < 0) std::reverse(loop.begin(), loop.end());
      int apex = -1;
      for (int k = 0; k < n && apex < 0; ++k) {
        bool ok = true;
        for (int i = 2; i + 1 < n && ok; ++i) ok = !share_face(loop[k], loop[(k + i) % n]);
        if (ok) apex = k;
      }
      FSKIN_CHECK(apex >= 0, "iso_surface: no fan apex for case {} (loop of {})", mask, n);
      for (int i = 1; i + 1 < n; ++i)
        table.triangles[mask].push_back(
            {loop[apex], loop[(apex + i) % n], loop[(apex + i + 1) % n]});
    }
  }
  return table;
}

const CaseTable& case_table() {
  static const CaseTable table = build_case_table();
  return table;
}

}  // namespace

Mesh iso_surface(const torch::Tensor& values, const GridBox& box,
                 const IsoSurfaceOptions& options) {
  expect_shape(values, {-1, -1, -1}, "iso_surface: values");
  expect_floating(values, "iso_surface: values");
  expect_finite(values, "iso_surface: values");
  const int64_t D = values.size(0), H = values.size(1), W = values.size(2);
  FSKIN_CHECK(D >= 2 && H >= 2 && W >= 2, "iso_surface: values must be at least 2x2x2, got {}",
              shape_string(values.sizes()));
  for (int axis = 0; axis < 3; ++axis)
    FSKIN_CHECK(box.voxel_size[axis] > 0 && std::isfinite(box.voxel_size[axis]) &&
                    std::isfinite(box.origin[axis]),
                "iso_surface: voxel size must be positive and the origin finite (axis {})", axis);
  const auto grid = values.to(torch::kCPU, torch::kFloat32).contiguous();
  const float* field = grid.data_ptr<float>();
  const float iso = static_cast<float>(options.iso);
  const bool above = options.inside_above;
  const auto inside = [&](float v) { return above ? v > iso : v < iso; };
  const int64_t strides[3] = {1, W, H * W};  // x, y, z

  // Pass 1: one vertex per crossing grid edge, keyed by 3 * (lower sample) + axis.
  // Keys come out sorted, so a vertex's index is its key's rank.
  std::vector<std::vector<int64_t>> layer_keys(D);
  std::vector<std::vector<float>> layer_points(D);
  at::parallel_for(0, D, 1, [&](int64_t begin, int64_t end) {
    for (int64_t k = begin; k < end; ++k) {
      auto& keys = layer_keys[k];
      auto& points = layer_points[k];
      for (int64_t j = 0; j < H; ++j)
        for (int64_t i = 0; i < W; ++i) {
          const int64_t index = (k * H + j) * W + i;
          const float v0 = field[index];
          const bool in0 = inside(v0);
          const bool has_next[3] = {i + 1 < W, j + 1 < H, k + 1 < D};
          for (int axis = 0; axis < 3; ++axis) {
            if (!has_next[axis]) continue;
            const float v1 = field[index + strides[axis]];
            if (inside(v1) == in0) continue;
            // Clamped away from the samples so no two vertices coincide.
            const double t =
                std::clamp((iso - double(v0)) / (double(v1) - double(v0)), 1e-4, 1.0 - 1e-4);
            auto p = box.point(k, j, i);
            p[axis] += t * box.voxel_size[axis];
            keys.push_back(3 * index + axis);
            points.insert(points.end(), {float(p[0]), float(p[1]), float(p[2])});
          }
        }
    }
  });
  std::vector<int64_t> keys;
  std::vector<float> points;
  for (int64_t k = 0; k < D; ++k) {
    keys.insert(keys.end(), layer_keys[k].begin(), layer_keys[k].end());
    points.insert(points.end(), layer_points[k].begin(), layer_points[k].end());
    std::vector<int64_t>().swap(layer_keys[k]);
    std::vector<float>().swap(layer_points[k]);
  }

  // Pass 2: triangles of every cube from the case table.
  const auto& table = case_table();
  std::vector<std::vector<int64_t>> layer_faces(D - 1);
  at::parallel_for(0, D - 1, 1, [&](int64_t begin, int64_t end) {
    for (int64_t k = begin; k < end; ++k) {
      auto& faces = layer_faces[k];
      for (int64_t j = 0; j + 1 < H; ++j)
        for (int64_t i = 0; i + 1 < W; ++i) {
          const int64_t base = (k * H + j) * W + i;
          int mask = 0;
          for (int c = 0; c < 8; ++c) {
            const int64_t index = base + corner_bit(c, 0) * strides[0] +
                                  corner_bit(c, 1) * strides[1] + corner_bit(c, 2) * strides[2];
            mask |= int(inside(field[index])) << c;
          }
          for (const auto& triangle : table.triangles[mask])
            for (int e : triangle) {
              const auto& edge = table.edges[e];
              const int64_t lower = base + corner_bit(edge.from, 0) * strides[0] +
                                    corner_bit(edge.from, 1) * strides[1] +
                                    corner_bit(edge.from, 2) * strides[2];
              const int64_t key = 3 * lower + edge.axis;
              faces.push_back(std::lower_bound(keys.begin(), keys.end(), key) - keys.begin());
            }
        }
    }
  });
  std::vector<int64_t> faces;
  for (auto& layer : layer_faces) faces.insert(faces.end(), layer.begin(), layer.end());

  const auto num_vertices = static_cast<int64_t>(keys.size());
  const auto num_faces = static_cast<int64_t>(faces.size() / 3);
  Mesh mesh;
  mesh.vertices = torch::from_blob(points.data(), {num_vertices, 3}, torch::kFloat32).clone();
  mesh.faces = torch::from_blob(faces.data(), {num_faces, 3}, torch::kInt64).clone();
  return mesh;
}

torch::Tensor sample_grid(const ScalarField& field, const GridBox& box,
                          const std::array<int64_t, 3>& dims, int64_t batch_size) {
  const int64_t D = dims[0], H = dims[1], W = dims[2];
  FSKIN_CHECK(D >= 1 && H >= 1 && W >= 1, "sample_grid: dims must be positive, got [{}, {}, {}]", D,
              H, W);
  FSKIN_CHECK(batch_size > 0, "sample_grid: batch_size must be positive, got {}", batch_size);
  auto out = torch::empty({D * H * W}, torch::kFloat32);
  for (int64_t start = 0; start < D * H * W; start += batch_size) {
    const int64_t end = std::min(D * H * W, start + batch_size);
    const auto index = torch::arange(start, end, torch::kInt64);
    const auto i = index.remainder(W), j = index.div(W, "floor").remainder(H),
               k = index.div(H * W, "floor");
    const auto points = torch::stack({i.to(torch::kFloat64) * box.voxel_size[0] + box.origin[0],
                                      j.to(torch::kFloat64) * box.voxel_size[1] + box.origin[1],
                                      k.to(torch::kFloat64) * box.voxel_size[2] + box.origin[2]},
                                     1)
                            .to(torch::kFloat32);
    const auto values = field(points);
    FSKIN_CHECK(values.defined() && values.numel() == end - start,
                "sample_grid: the field returned {} values for {} points",
                values.defined() ? values.numel() : 0, end - start);
    out.slice(0, start, end).copy_(values.reshape({-1}).to(torch::kCPU, torch::kFloat32));
  }
  return out.reshape({D, H, W});
}

Mesh iso_surface(const ScalarField& field, const GridBox& box, const std::array<int64_t, 3>& dims,
                 const IsoSurfaceOptions& options) {
  return iso_surface(sample_grid(field, box, dims), box, options);
}

}  // namespace fskin
