#pragma once
// Topology and simple measures of triangle meshes: edge statistics, Euler
// characteristic, closed-manifold test, connected components, clean-up,
// vertex normals, area and enclosed volume.
#include <torch/types.h>

#include "fskin/geometry/mesh.h"

namespace fskin {

struct MeshTopology {
  int64_t num_vertices = 0;  // vertices referenced by at least one face
  int64_t num_edges = 0;     // undirected
  int64_t num_faces = 0;
  int64_t boundary_edges = 0;         // used by exactly one face
  int64_t non_manifold_edges = 0;     // used by more than two faces
  int64_t misoriented_edges = 0;      // used twice in the same direction (faces flipped)
  int64_t non_manifold_vertices = 0;  // faces around the vertex form more than one fan

  int64_t euler_characteristic() const { return num_vertices - num_edges + num_faces; }
  // Every edge shared by exactly two oppositely oriented faces and every vertex
  // surrounded by a single fan: the boundary of a solid.
  bool is_closed_manifold() const {
    return num_faces > 0 && boundary_edges == 0 && non_manifold_edges == 0 &&
           misoriented_edges == 0 && non_manifold_vertices == 0;
  }
};

MeshTopology analyze_topology(const Mesh& mesh);
bool is_closed_manifold(const Mesh& mesh);

// Faces are connected when they share a vertex.
struct MeshComponents {
  torch::Tensor face_labels;  // [F] int64 in [0, count), numbered by first face
  int64_t count = 0;
};
MeshComponents connected_components(const Mesh& mesh);

// The component with the most faces (ties: the lowest label), without the
// vertices it does not use.
Mesh keep_largest_component(const Mesh& mesh);

// Drops vertices (and their colours) that no face references; keeps order.
Mesh remove_unreferenced_vertices(const Mesh& mesh);

// Area-weighted vertex normals [V, 3], unit length (zero for unused vertices).
torch::Tensor vertex_normals(const Mesh& mesh);

double surface_area(const Mesh& mesh);
// Positive for a closed mesh whose faces are counter-clockwise seen from outside.
double signed_volume(const Mesh& mesh);

}  // namespace fskin
