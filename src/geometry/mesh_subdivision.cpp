#include "fskin/geometry/mesh_subdivision.h"

#include <torch/torch.h>

#include <unordered_map>
#include <vector>

#include "fskin/core/tensor_checks.h"

namespace fskin {

SubdividedMesh subdivide_midpoints(const Mesh& mesh) {
  mesh.validate("subdivide_midpoints");
  const int64_t vertex_count = mesh.num_vertices(), face_count = mesh.num_faces();
  const auto faces = mesh.faces.contiguous();
  const int64_t* f = faces.data_ptr<int64_t>();
  std::vector<int64_t> parents;
  parents.reserve(2 * (vertex_count + 3 * face_count / 2 + 1));
  for (int64_t v = 0; v < vertex_count; ++v) parents.insert(parents.end(), {v, v});
  // One new vertex per undirected edge, shared by the faces on either side.
  std::unordered_map<uint64_t, int64_t> midpoint_of;
  midpoint_of.reserve(static_cast<size_t>(3 * face_count));
  const auto midpoint = [&](int64_t a, int64_t b) {
    const uint64_t key = static_cast<uint64_t>(std::min(a, b)) * static_cast<uint64_t>(vertex_count) +
                         static_cast<uint64_t>(std::max(a, b));
    const auto [it, inserted] = midpoint_of.emplace(key, static_cast<int64_t>(parents.size() / 2));
    if (inserted) parents.insert(parents.end(), {std::min(a, b), std::max(a, b)});
    return it->second;
  };
  std::vector<int64_t> split;
  split.reserve(static_cast<size_t>(12 * face_count));
  for (int64_t i = 0; i < face_count; ++i) {
    const int64_t a = f[3 * i], b = f[3 * i + 1], c = f[3 * i + 2];
    const int64_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    // The corners' triangles and the middle one, all wound as the face.
    split.insert(split.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
  }
  SubdividedMesh out;
  out.parents = torch::tensor(parents, torch::kInt64).view({-1, 2});
  out.mesh.vertices = carry_to_subdivision(mesh.vertices, out.parents);
  out.mesh.faces = torch::tensor(split, torch::kInt64).view({-1, 3});
  return out;
}

torch::Tensor carry_to_subdivision(const torch::Tensor& values, const torch::Tensor& parents) {
  expect_shape(parents, {-1, 2}, "carry_to_subdivision: parents");
  expect_shape(values, {-1, -1}, "carry_to_subdivision: values");
  return 0.5 * (values.index_select(0, parents.select(1, 0)) + values.index_select(0, parents.select(1, 1)));
}

}  // namespace fskin
