#include "fskin/geometry/mesh_topology.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

namespace fskin {
namespace {

// Unit cube [0, 1]^3 as 12 triangles, counter-clockwise seen from outside.
Mesh unit_cube() {
  Mesh mesh;
  mesh.vertices =
      torch::tensor({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1},
                    torch::kFloat32)
          .reshape({8, 3});
  mesh.faces = torch::tensor({0, 2, 1, 1, 2, 3,   // z = 0, normal -z
                              4, 5, 6, 5, 7, 6,   // z = 1, normal +z
                              0, 1, 4, 1, 5, 4,   // y = 0, normal -y
                              2, 6, 3, 3, 6, 7,   // y = 1, normal +y
                              0, 4, 2, 2, 4, 6,   // x = 0, normal -x
                              1, 3, 5, 3, 7, 5},  // x = 1, normal +x
                             torch::kInt64)
                   .reshape({12, 3});
  return mesh;
}

Mesh translated(Mesh mesh, float dx) {
  mesh.vertices = mesh.vertices + torch::tensor({dx, 0.0f, 0.0f});
  return mesh;
}

Mesh concatenate(const Mesh& a, const Mesh& b) {
  return Mesh{
      torch::cat({a.vertices, b.vertices}), torch::cat({a.faces, b.faces + a.num_vertices()}), {}};
}

TEST(MeshTopology, CubeIsClosedManifoldWithEulerTwo) {
  const auto cube = unit_cube();
  const auto t = analyze_topology(cube);
  EXPECT_TRUE(t.is_closed_manifold());
  EXPECT_EQ(t.num_vertices, 8);
  EXPECT_EQ(t.num_edges, 18);
  EXPECT_EQ(t.euler_characteristic(), 2);
  EXPECT_NEAR(surface_area(cube), 6.0, 1e-9);
  EXPECT_NEAR(signed_volume(cube), 1.0, 1e-9);
  // Corner normals are unit vectors pointing away from the centre; corner 0
  // touches one triangle of each side, so its normal is the diagonal.
  const auto normals = vertex_normals(cube);
  EXPECT_TRUE(torch::allclose(normals.norm(2, 1), torch::ones({8})));
  EXPECT_GT((normals * (cube.vertices - 0.5)).sum(1).min().item<float>(), 0.4f);
  EXPECT_TRUE(torch::allclose(normals[0], torch::full({3}, -1.0f / std::sqrt(3.0f))));
}

TEST(MeshTopology, OpenMeshHasBoundaryEdges) {
  auto open = unit_cube();
  open.faces = open.faces.slice(0, 2);  // remove the z = 0 side
  const auto t = analyze_topology(open);
  EXPECT_FALSE(t.is_closed_manifold());
  EXPECT_EQ(t.boundary_edges, 4);
  EXPECT_EQ(t.non_manifold_edges, 0);
  EXPECT_EQ(t.euler_characteristic(), 1);  // a disc
}

TEST(MeshTopology, FlippedFaceIsMisoriented) {
  auto cube = unit_cube();
  cube.faces[0] = torch::tensor({0, 1, 2});
  const auto t = analyze_topology(cube);
  EXPECT_EQ(t.misoriented_edges, 3);
  EXPECT_FALSE(t.is_closed_manifold());
  EXPECT_EQ(t.boundary_edges, 0);
}

TEST(MeshTopology, ThreeFacesOnAnEdgeAreNonManifold) {
  auto cube = unit_cube();
  // An extra fin triangle on the edge (0, 1).
  cube.vertices = torch::cat({cube.vertices, torch::tensor({{0.5f, -1.0f, -1.0f}})});
  cube.faces = torch::cat({cube.faces, torch::tensor({{0, 1, 8}}, torch::kInt64)});
  const auto t = analyze_topology(cube);
  EXPECT_EQ(t.non_manifold_edges, 1);
  EXPECT_FALSE(t.is_closed_manifold());
}

TEST(MeshTopology, CubesSharingOneVertexArePinched) {
  // Second cube touches the first only at vertex 7 = (1, 1, 1).
  auto second = unit_cube();
  second.vertices = second.vertices + 1.0f;
  auto faces = second.faces + 8;
  faces.masked_fill_(faces == 8, 7);  // its corner (0,0,0)+1 is the first cube's vertex 7
  Mesh both{torch::cat({unit_cube().vertices, second.vertices}),
            torch::cat({unit_cube().faces, faces}),
            {}};
  const auto t = analyze_topology(both);
  EXPECT_EQ(t.boundary_edges, 0);
  EXPECT_EQ(t.non_manifold_edges, 0);
  EXPECT_EQ(t.non_manifold_vertices, 1);
  EXPECT_FALSE(t.is_closed_manifold());
  EXPECT_EQ(connected_components(both).count, 1);
}

TEST(MeshTopology, ComponentsAndKeepLargest) {
  auto small = unit_cube();
  small.vertices = small.vertices * 0.5f;
  // Two cubes; the second one gets an extra split face so it has more faces.
  auto big = translated(unit_cube(), 3.0f);
  big.vertices = torch::cat({big.vertices, torch::tensor({{3.5f, 0.5f, 0.0f}})});
  big.faces =
      torch::cat({big.faces.slice(0, 2),
                  torch::tensor({{0, 2, 8}, {2, 3, 8}, {3, 1, 8}, {1, 0, 8}}, torch::kInt64)});
  const auto mesh = concatenate(small, big);
  const auto components = connected_components(mesh);
  EXPECT_EQ(components.count, 2);
  EXPECT_EQ(components.face_labels[0].item<int64_t>(), 0);
  EXPECT_EQ(components.face_labels[12].item<int64_t>(), 1);
  const auto largest = keep_largest_component(mesh);
  EXPECT_EQ(largest.num_faces(), 14);
  EXPECT_EQ(largest.num_vertices(), 9);
  EXPECT_TRUE(is_closed_manifold(largest));
  EXPECT_NEAR(signed_volume(largest), 1.0, 1e-6);
  EXPECT_GE(largest.vertices.select(1, 0).min().item<float>(), 3.0f);
}

TEST(MeshTopology, RemoveUnreferencedVerticesKeepsOrderAndColours) {
  auto cube = unit_cube();
  // Insert an unused vertex at index 0 and shift the faces.
  cube.vertices = torch::cat({torch::tensor({{9.0f, 9.0f, 9.0f}}), cube.vertices});
  cube.faces = cube.faces + 1;
  cube.colors = torch::arange(27, torch::kUInt8).reshape({9, 3});
  const auto cleaned = remove_unreferenced_vertices(cube);
  EXPECT_TRUE(torch::equal(cleaned.vertices, unit_cube().vertices));
  EXPECT_TRUE(torch::equal(cleaned.faces, unit_cube().faces));
  EXPECT_TRUE(torch::equal(cleaned.colors, cube.colors.slice(0, 1)));
}

}  // namespace
}  // namespace fskin
