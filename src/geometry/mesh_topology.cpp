#include "fskin/geometry/mesh_topology.h"

#include <torch/torch.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>
#include <vector>

#include "fskin/core/error.h"

namespace fskin {
namespace {

// Union-find with path halving; the smaller index becomes the root, so labels
// do not depend on the order of unions.
struct DisjointSets {
  explicit DisjointSets(int64_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int64_t find(int64_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(int64_t a, int64_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<int64_t> parent;
};

std::vector<int64_t> face_indices(const Mesh& mesh) {
  mesh.validate("mesh");
  const auto faces = mesh.faces.contiguous();
  return std::vector<int64_t>(faces.data_ptr<int64_t>(), faces.data_ptr<int64_t>() + faces.numel());
}

std::vector<Eigen::Vector3d> vertex_positions(const Mesh& mesh) {
  const auto vertices = mesh.vertices.to(torch::kFloat64).contiguous();
  const double* p = vertices.data_ptr<double>();
  std::vector<Eigen::Vector3d> out(mesh.num_vertices());
  for (size_t v = 0; v < out.size(); ++v) out[v] = {p[3 * v], p[3 * v + 1], p[3 * v + 2]};
  return out;
}

}  // namespace

MeshTopology analyze_topology(const Mesh& mesh) {
  const auto faces = face_indices(mesh);
  const int64_t V = mesh.num_vertices(), F = mesh.num_faces();
  MeshTopology topology;
  topology.num_faces = F;

  // Undirected edge key with the direction it is used in (+1: low -> high).
  std::vector<std::pair<int64_t, int>> edges;
  edges.reserve(3 * F);
  for (int64_t f = 0; f < F; ++f)
    for (int c = 0; c < 3; ++c) {
      const int64_t a = faces[3 * f + c], b = faces[3 * f + (c + 1) % 3];
      edges.emplace_back(std::min(a, b) * V + std::max(a, b), a < b ? 1 : -1);
    }
  std::sort(edges.begin(), edges.end());
  for (size_t first = 0; first < edges.size();) {
    size_t last = first;
    int forward = 0;
    for (; last < edges.size() && edges[last].first == edges[first].first; ++last)
      forward += edges[last].second > 0;
    const size_t uses = last - first;
    ++topology.num_edges;
    if (uses == 1)
      ++topology.boundary_edges;
    else if (uses > 2)
      ++topology.non_manifold_edges;
    else if (forward != 1)
      ++topology.misoriented_edges;
    first = last;
  }

  // Around each vertex, the opposite edges of its faces (its link) must form a
  // single connected path or cycle; several pieces mean a pinched vertex.
  std::vector<int64_t> offsets(V + 1, 0);
  for (int64_t v : faces) ++offsets[v + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  std::vector<std::pair<int64_t, int64_t>> link(3 * F);
  std::vector<int64_t> fill(offsets.begin(), offsets.end() - 1);
  for (int64_t f = 0; f < F; ++f)
    for (int c = 0; c < 3; ++c)
      link[fill[faces[3 * f + c]]++] = {faces[3 * f + (c + 1) % 3], faces[3 * f + (c + 2) % 3]};
  std::vector<int64_t> neighbours;
  for (int64_t v = 0; v < V; ++v) {
    if (offsets[v] == offsets[v + 1]) continue;
    ++topology.num_vertices;
    neighbours.clear();
    for (int64_t i = offsets[v]; i < offsets[v + 1]; ++i) {
      neighbours.push_back(link[i].first);
      neighbours.push_back(link[i].second);
    }
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
    const auto local = [&](int64_t u) {
      return std::lower_bound(neighbours.begin(), neighbours.end(), u) - neighbours.begin();
    };
    DisjointSets sets(static_cast<int64_t>(neighbours.size()));
    for (int64_t i = offsets[v]; i < offsets[v + 1]; ++i)
      sets.unite(local(link[i].first), local(link[i].second));
    int64_t fans = 0;
    for (int64_t i = 0; i < static_cast<int64_t>(neighbours.size()); ++i) fans += sets.find(i) == i;
    if (fans > 1) ++topology.non_manifold_vertices;
  }
  return topology;
}

bool is_closed_manifold(const Mesh& mesh) { return analyze_topology(mesh).is_closed_manifold(); }

MeshComponents connected_components(const Mesh& mesh) {
  const auto faces = face_indices(mesh);
  const int64_t F = mesh.num_faces();
  DisjointSets sets(mesh.num_vertices());
  for (int64_t f = 0; f < F; ++f) {
    sets.unite(faces[3 * f], faces[3 * f + 1]);
    sets.unite(faces[3 * f], faces[3 * f + 2]);
  }
  MeshComponents components;
  components.face_labels = torch::empty({F}, torch::kInt64);
  auto labels = components.face_labels.accessor<int64_t, 1>();
  std::vector<int64_t> label_of_root(mesh.num_vertices(), -1);
  for (int64_t f = 0; f < F; ++f) {
    int64_t& label = label_of_root[sets.find(faces[3 * f])];
    if (label < 0) label = components.count++;
    labels[f] = label;
  }
  return components;
}

Mesh keep_largest_component(const Mesh& mesh) {
  const auto components = connected_components(mesh);
  if (components.count <= 1) return remove_unreferenced_vertices(mesh);
  const auto sizes = torch::bincount(components.face_labels, {}, components.count);
  const int64_t largest = sizes.argmax().item<int64_t>();  // first maximum
  Mesh kept = mesh;
  kept.faces = mesh.faces.index({components.face_labels == largest}).contiguous();
  return remove_unreferenced_vertices(kept);
}

Mesh remove_unreferenced_vertices(const Mesh& mesh) {
  mesh.validate("mesh");
  const int64_t V = mesh.num_vertices();
  auto used = torch::zeros({V}, torch::kBool);
  if (mesh.num_faces() > 0) used.index_put_({mesh.faces.reshape({-1})}, true);
  const auto new_index = used.to(torch::kInt64).cumsum(0) - 1;
  Mesh out;
  out.vertices = mesh.vertices.index({used}).contiguous();
  out.faces = new_index.index({mesh.faces}).contiguous();
  if (mesh.colors.defined()) out.colors = mesh.colors.index({used}).contiguous();
  return out;
}

torch::Tensor vertex_normals(const Mesh& mesh) {
  const auto faces = face_indices(mesh);
  const auto points = vertex_positions(mesh);
  std::vector<Eigen::Vector3d> normals(points.size(), Eigen::Vector3d::Zero());
  for (size_t f = 0; f < faces.size() / 3; ++f) {
    const int64_t a = faces[3 * f], b = faces[3 * f + 1], c = faces[3 * f + 2];
    // |cross| is twice the face area: area weighting comes for free.
    const Eigen::Vector3d n = (points[b] - points[a]).cross(points[c] - points[a]);
    normals[a] += n;
    normals[b] += n;
    normals[c] += n;
  }
  auto out = torch::zeros({mesh.num_vertices(), 3}, torch::kFloat32);
  auto o = out.accessor<float, 2>();
  for (size_t v = 0; v < normals.size(); ++v) {
    const double length = normals[v].norm();
    if (length > 0)
      for (int c = 0; c < 3; ++c) o[v][c] = static_cast<float>(normals[v][c] / length);
  }
  return out;
}

double surface_area(const Mesh& mesh) {
  const auto faces = face_indices(mesh);
  const auto points = vertex_positions(mesh);
  double area = 0;
  for (size_t f = 0; f < faces.size() / 3; ++f) {
    const auto& a = points[faces[3 * f]];
    area += 0.5 * (points[faces[3 * f + 1]] - a).cross(points[faces[3 * f + 2]] - a).norm();
  }
  return area;
}

double signed_volume(const Mesh& mesh) {
  const auto faces = face_indices(mesh);
  const auto points = vertex_positions(mesh);
  double volume = 0;
  // Divergence theorem: sum of the signed volumes of tetrahedra (origin, face).
  for (size_t f = 0; f < faces.size() / 3; ++f)
    volume += points[faces[3 * f]].dot(points[faces[3 * f + 1]].cross(points[faces[3 * f + 2]]));
  return volume / 6.0;
}

}  // namespace fskin
