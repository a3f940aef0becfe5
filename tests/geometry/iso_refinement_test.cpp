// Vertices moved onto the level set: no terraces on nearly binary fields.
#include "fskin/geometry/iso_refinement.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/geometry/mesh_topology.h"
#include "fskin/geometry/mise.h"
#include "test_util.h"

namespace fskin {
namespace {

constexpr double kRadius = 0.61;

// A learned occupancy's look: a logit that saturates at +-15 within a tenth
// of a grid cell of the sphere's surface.
torch::Tensor steep_sphere(const torch::Tensor& p, double cell) {
  return 15.0 * torch::tanh((kRadius - p.norm(2, 1)) / (0.1 * cell));
}

// Root mean square of |v| - radius over the vertices, in cells.
double radius_error(const Mesh& mesh, double cell) {
  return ((mesh.vertices.norm(2, 1) - kRadius).square().mean().sqrt() / cell).item<double>();
}

TEST(IsoRefinement, PutsTheVerticesOfANearlyBinaryFieldOnItsSurface) {
  const int64_t n = 33;
  const double cell = 2.0 / (n - 1);
  const auto box = GridBox::spanning({-1, -1, -1}, {1, 1, 1}, {n, n, n});
  const ScalarField field = [&](const torch::Tensor& p) { return steep_sphere(p, cell); };
  const auto values = sample_grid(field, box, {n, n, n});
  const Mesh linear = iso_surface(values, box);
  // Linear interpolation of saturated samples: vertices near edge midpoints.
  EXPECT_GT(radius_error(linear, cell), 0.1);
  Mesh refined = linear;
  int64_t calls = 0;
  const auto stats = refine_iso_vertices(
      refined, values, box,
      [&](const torch::Tensor& p) {
        ++calls;
        return field(p);
      },
      0.0, 6, 1000);
  EXPECT_EQ(stats.vertices_moved, linear.num_vertices());
  EXPECT_EQ(stats.field_points, 6 * linear.num_vertices());
  EXPECT_EQ(calls, 6 * ((linear.num_vertices() + 999) / 1000));
  EXPECT_LT(radius_error(refined, cell), 0.01);
  // Same faces, still closed; every vertex stays on its edge.
  EXPECT_TRUE(torch::equal(refined.faces, linear.faces));
  EXPECT_TRUE(is_closed_manifold(refined));
  EXPECT_LT((refined.vertices - linear.vertices).abs().max().item<double>(), cell + 1e-6);
}

// Far from the origin on a fine grid, the float32 vertices sit thousandths of
// a cell off their edges' lines; each is still found and refined.
TEST(IsoRefinement, RefinesEveryVertexOfAFineGridFarFromTheOrigin) {
  const int64_t n = 97;
  const double cell = 0.4 / (n - 1);
  const double c[3] = {40.3, -25.1, 17.7};
  const torch::Tensor centre = torch::tensor({c[0], c[1], c[2]}, torch::kFloat64);
  const auto box = GridBox::spanning({c[0] - 0.2, c[1] - 0.2, c[2] - 0.2}, {c[0] + 0.2, c[1] + 0.2, c[2] + 0.2},
                                     {n, n, n});
  const double radius = 0.13;
  const ScalarField field = [&](const torch::Tensor& p) {
    return 15.0 * torch::tanh((radius - (p.to(torch::kFloat64) - centre).norm(2, 1)) / (0.1 * cell));
  };
  const auto values = sample_grid(field, box, {n, n, n});
  const Mesh linear = iso_surface(values, box);
  Mesh refined = linear;
  const auto stats = refine_iso_vertices(refined, values, box, field, 0.0, 6);
  EXPECT_EQ(stats.vertices_moved, linear.num_vertices());
  const auto error = [&](const Mesh& m) {
    return ((m.vertices.to(torch::kFloat64) - centre).norm(2, 1) - radius).square().mean().sqrt().item<double>() /
           cell;
  };
  EXPECT_GT(error(linear), 0.1);
  EXPECT_LT(error(refined), 0.05);  // float32 vertices 40 units out: ~4e-6 of rounding, 0.001 cells
}

TEST(IsoRefinement, LeavesALinearFieldWhereMarchingCubesPutIt) {
  // A plane: linear interpolation is already exact, and refinement keeps it.
  const int64_t n = 9;
  const auto box = GridBox::spanning({-1, -1, -1}, {1, 1, 1}, {n, n, n});
  const ScalarField plane = [](const torch::Tensor& p) { return 0.3 - p.select(1, 1) - 0.2 * p.select(1, 0); };
  const auto values = sample_grid(plane, box, {n, n, n});
  const Mesh linear = iso_surface(values, box);
  Mesh refined = linear;
  refine_iso_vertices(refined, values, box, plane, 0.0, 3);
  EXPECT_LT((refined.vertices - linear.vertices).abs().max().item<double>(), 1e-4);
}

TEST(IsoRefinement, MiseRefinesWhenAsked) {
  MiseOptions options = MiseOptions::resolutions(8, 32);
  const double cell = 2.0 / 32;
  const ScalarField field = [&](const torch::Tensor& p) { return steep_sphere(p, cell); };
  const auto plain = mise(field, {-1, -1, -1}, {1, 1, 1}, options);
  options.refinement_steps = 5;
  const auto refined = mise(field, {-1, -1, -1}, {1, 1, 1}, options);
  EXPECT_EQ(refined.stats.refinement_points, 5 * refined.mesh.num_vertices());
  EXPECT_EQ(plain.stats.refinement_points, 0);
  EXPECT_GT(radius_error(plain.mesh, cell), 0.1);
  EXPECT_LT(radius_error(refined.mesh, cell), 0.02);
  options.refinement_steps = 65;
  testing::expect_error([&] { mise(field, {-1, -1, -1}, {1, 1, 1}, options); }, {"refinement steps"});
}

}  // namespace
}  // namespace fskin
