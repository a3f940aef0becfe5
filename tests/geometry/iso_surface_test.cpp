#include "fskin/geometry/iso_surface.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "fskin/geometry/mesh_topology.h"
#include "test_util.h"

namespace fskin {
namespace {

// A grid of n^3 samples covering [-1, 1]^3.
GridBox unit_box(int64_t n) { return GridBox::spanning({-1, -1, -1}, {1, 1, 1}, {n, n, n}); }

// Signed distance to a sphere of `radius` at `centre`, negative inside.
ScalarField sphere_sdf(double radius, std::array<double, 3> centre = {0, 0, 0}) {
  return [=](const torch::Tensor& p) {
    const auto c = torch::tensor({centre[0], centre[1], centre[2]}, torch::kFloat32);
    return (p - c).norm(2, 1) - radius;
  };
}

TEST(IsoSurface, SphereIsClosedManifoldWithAnalyticAreaAndVolume) {
  const double r = 0.7;
  const int64_t n = 64;
  const auto mesh =
      iso_surface(sphere_sdf(r), unit_box(n), {n, n, n}, IsoSurfaceOptions{0.0, false});
  const auto topology = analyze_topology(mesh);
  EXPECT_TRUE(topology.is_closed_manifold());
  EXPECT_EQ(topology.euler_characteristic(), 2);
  EXPECT_EQ(connected_components(mesh).count, 1);
  EXPECT_NEAR(surface_area(mesh), 4 * M_PI * r * r, 0.01 * 4 * M_PI * r * r);
  EXPECT_NEAR(signed_volume(mesh), 4.0 / 3.0 * M_PI * r * r * r,
              0.01 * 4.0 / 3.0 * M_PI * r * r * r);
  // Every vertex lies on the sphere (up to the linear interpolation error).
  EXPECT_LT((mesh.vertices.norm(2, 1) - r).abs().max().item<float>(), 0.01);
  // Normals point outward: along the position for a sphere at the origin.
  const auto normals = vertex_normals(mesh);
  EXPECT_GT((normals * mesh.vertices / r).sum(1).min().item<float>(), 0.95);
}

TEST(IsoSurface, InsideConventionFlipsOrientationNotGeometry) {
  const int64_t n = 24;
  // Occupancy-like field: inside where the value is above 0.5.
  const auto occupancy = [](const torch::Tensor& p) { return 1.0 - p.norm(2, 1); };
  const auto above = iso_surface(occupancy, unit_box(n), {n, n, n}, IsoSurfaceOptions{0.5, true});
  const auto below = iso_surface([&](const torch::Tensor& p) { return -occupancy(p); }, unit_box(n),
                                 {n, n, n}, IsoSurfaceOptions{-0.5, false});
  EXPECT_GT(signed_volume(above), 0.0);
  EXPECT_TRUE(torch::equal(above.vertices, below.vertices));
  EXPECT_TRUE(torch::equal(above.faces, below.faces));
}

TEST(IsoSurface, RandomFieldsGiveClosedManifolds) {
  // Noise maximises ambiguous faces and cubes; zero borders close the surface.
  torch::manual_seed(3);
  for (int trial = 0; trial < 20; ++trial) {
    auto values = torch::zeros({12, 10, 11});
    values.slice(0, 1, 11).slice(1, 1, 9).slice(2, 1, 10).copy_(torch::rand({10, 8, 9}));
    const auto mesh = iso_surface(values, GridBox{}, IsoSurfaceOptions{0.5, true});
    ASSERT_GT(mesh.num_faces(), 0);
    const auto topology = analyze_topology(mesh);
    EXPECT_TRUE(topology.is_closed_manifold()) << "trial " << trial;
    EXPECT_EQ(topology.num_vertices, mesh.num_vertices());  // no unused or duplicate vertices
    EXPECT_GT(signed_volume(mesh), 0.0);
    // No two vertices share a position.
    const auto unique = std::get<0>(torch::unique_dim(mesh.vertices, 0));
    EXPECT_EQ(unique.size(0), mesh.num_vertices());
  }
}

TEST(IsoSurface, EveryCubeConfigurationGivesClosedManifolds) {
  // Each of the 256 sign patterns on the corners of the middle cube of a 4^3
  // grid whose other samples are outside; pairs of patterns in two adjacent
  // cubes exercise the shared-face rule.
  for (int mask = 1; mask < 256; ++mask) {
    auto values = torch::zeros({4, 4, 5});
    for (int c = 0; c < 8; ++c)
      values[1 + (c >> 2 & 1)][1 + (c >> 1 & 1)][1 + (c & 1)] = (mask >> c) & 1;
    values[1][1][3] = values[2][2][3] = mask & 1;  // a neighbour cube sharing the x = 2 face
    const auto mesh = iso_surface(values, GridBox{}, IsoSurfaceOptions{0.5, true});
    EXPECT_TRUE(is_closed_manifold(mesh)) << "mask " << mask;
    EXPECT_GT(signed_volume(mesh), 0.0) << "mask " << mask;
  }
}

TEST(IsoSurface, TwoSpheresGiveTwoComponentsAndKeepLargestPicksTheBigOne) {
  const int64_t n = 40;
  const auto field = [](const torch::Tensor& p) {
    const auto a = (p - torch::tensor({-0.45f, 0.0f, 0.0f})).norm(2, 1) - 0.4;
    const auto b = (p - torch::tensor({0.6f, 0.0f, 0.0f})).norm(2, 1) - 0.25;
    return torch::minimum(a, b);
  };
  const auto mesh = iso_surface(field, unit_box(n), {n, n, n}, IsoSurfaceOptions{0.0, false});
  EXPECT_EQ(connected_components(mesh).count, 2);
  EXPECT_EQ(analyze_topology(mesh).euler_characteristic(), 4);
  const auto largest = keep_largest_component(mesh);
  EXPECT_TRUE(is_closed_manifold(largest));
  EXPECT_LT(largest.vertices.select(1, 0).max().item<float>(), 0.0);
  EXPECT_NEAR(signed_volume(largest), 4.0 / 3.0 * M_PI * 0.064, 0.03 * 4.0 / 3.0 * M_PI * 0.064);
}

TEST(IsoSurface, AnisotropicBoxAndOffsetOrigin) {
  const GridBox box{{1.0, 2.0, 3.0}, {0.02, 0.03, 0.05}};
  const std::array<int64_t, 3> dims{20, 30, 40};  // z, y, x: box 0.8 x 0.87 x 0.95
  const auto mesh =
      iso_surface(sphere_sdf(0.3, {1.4, 2.45, 3.5}), box, dims, IsoSurfaceOptions{0.0, false});
  EXPECT_TRUE(is_closed_manifold(mesh));
  const auto centre = mesh.vertices.mean(0);
  EXPECT_TRUE(torch::allclose(centre, torch::tensor({1.4f, 2.45f, 3.5f}), 0, 0.01));
  EXPECT_NEAR(signed_volume(mesh), 4.0 / 3.0 * M_PI * 0.027, 0.05 * 4.0 / 3.0 * M_PI * 0.027);
}

TEST(IsoSurface, EmptyAndFullFieldsGiveNoFaces) {
  EXPECT_EQ(iso_surface(torch::zeros({3, 3, 3}), GridBox{}).num_faces(), 0);
  EXPECT_EQ(iso_surface(torch::ones({3, 3, 3}), GridBox{}).num_faces(), 0);
}

TEST(IsoSurface, RejectsBadInput) {
  testing::expect_error(
      [] {
        iso_surface(torch::zeros({3, 3}), GridBox{});
      },
      {"iso_surface: values", "[3, 3]"});
  testing::expect_error(
      [] {
        iso_surface(torch::zeros({1, 3, 3}), GridBox{});
      },
      {"iso_surface", "at least 2x2x2"});
  auto nan = torch::zeros({3, 3, 3});
  nan[1][1][1] = NAN;
  testing::expect_error([&] { iso_surface(nan, GridBox{}); }, {"iso_surface: values"});
  testing::expect_error(
      [] {
        iso_surface(torch::zeros({3, 3, 3}), GridBox{{0, 0, 0}, {1, 0, 1}});
      },
      {"iso_surface", "voxel size"});
  const auto wrong_count = [](const torch::Tensor& p) { return torch::zeros({p.size(0) + 1}); };
  testing::expect_error(
      [&] {
        sample_grid(wrong_count, GridBox{}, {2, 2, 2});
      },
      {"sample_grid", "9 values for 8 points"});
}

TEST(SampleGrid, MatchesGridLayoutAcrossBatches) {
  const GridBox box{{0.5, -1.0, 2.0}, {0.1, 0.2, 0.3}};
  // Value = x + 10 y + 100 z, sampled with a batch size that splits rows.
  const auto field = [](const torch::Tensor& p) {
    return p.select(1, 0) + 10 * p.select(1, 1) + 100 * p.select(1, 2);
  };
  const auto grid = sample_grid(field, box, {3, 4, 5}, 7);
  ASSERT_EQ(grid.sizes(), (std::vector<int64_t>{3, 4, 5}));
  const auto p = box.point(2, 1, 3);
  const auto spanning = GridBox::spanning({0.5, -1.0, 2.0}, {0.9, -0.4, 2.6}, {3, 4, 5});
  for (int axis = 0; axis < 3; ++axis)
    EXPECT_NEAR(spanning.voxel_size[axis], box.voxel_size[axis], 1e-12);
  EXPECT_NEAR(grid[2][1][3].item<float>(), p[0] + 10 * p[1] + 100 * p[2], 1e-3);
}

}  // namespace
}  // namespace fskin
