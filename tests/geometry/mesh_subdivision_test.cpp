#include "fskin/geometry/mesh_subdivision.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/geometry/mesh_topology.h"

namespace fskin {
namespace {

// Unit cube [0, 1]^3 as 12 triangles, counter-clockwise seen from outside.
Mesh unit_cube() {
  Mesh mesh;
  mesh.vertices =
      torch::tensor({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1}, torch::kFloat32)
          .reshape({8, 3});
  mesh.faces = torch::tensor({0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                              2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5},
                             torch::kInt64)
                   .reshape({12, 3});
  return mesh;
}

TEST(MeshSubdivision, SplitsEveryFaceInFourAndSharesTheEdgesMidpoints) {
  const auto cube = unit_cube();
  const auto once = subdivide_midpoints(cube);
  // 8 vertices + 18 edges; 48 faces; still closed, outward and of the same area and volume.
  EXPECT_EQ(once.mesh.num_vertices(), 8 + 18);
  EXPECT_EQ(once.mesh.num_faces(), 48);
  EXPECT_TRUE(analyze_topology(once.mesh).is_closed_manifold());
  EXPECT_NEAR(surface_area(once.mesh), 6.0, 1e-5);
  EXPECT_NEAR(signed_volume(once.mesh), 1.0, 1e-5);
  // The old vertices first and unchanged; each new one halfway between its parents.
  EXPECT_TRUE(torch::equal(once.mesh.vertices.narrow(0, 0, 8), cube.vertices));
  for (int64_t v = 8; v < once.mesh.num_vertices(); ++v) {
    const auto a = once.parents[v][0].item<int64_t>(), b = once.parents[v][1].item<int64_t>();
    EXPECT_NE(a, b);
    EXPECT_TRUE(torch::allclose(once.mesh.vertices[v], 0.5 * (cube.vertices[a] + cube.vertices[b])));
  }
  const auto twice = subdivide_midpoints(once.mesh);
  EXPECT_EQ(twice.mesh.num_faces(), 192);
  EXPECT_TRUE(analyze_topology(twice.mesh).is_closed_manifold());
}

TEST(MeshSubdivision, CarriedWeightsStillSumToOne) {
  const auto cube = unit_cube();
  const auto once = subdivide_midpoints(cube);
  const auto weights = torch::softmax(torch::randn({8, 5}), 1);
  const auto carried = carry_to_subdivision(weights, once.parents);
  ASSERT_EQ(carried.sizes(), (std::vector<int64_t>{26, 5}));
  EXPECT_TRUE(torch::allclose(carried.sum(1), torch::ones({26}), 0, 1e-6));
  EXPECT_TRUE(torch::equal(carried.narrow(0, 0, 8), weights));
}

TEST(MeshSubdivision, AnInvalidMeshIsRefused) {
  auto broken = unit_cube();
  broken.faces[0][0] = 99;
  EXPECT_THROW(subdivide_midpoints(broken), Error);
}

}  // namespace
}  // namespace fskin
