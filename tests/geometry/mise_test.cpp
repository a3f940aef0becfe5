#include "fskin/geometry/mise.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "fskin/geometry/mesh_topology.h"
#include "test_util.h"

namespace fskin {
namespace {

// Logit-like fields: positive inside, zero on the surface.
torch::Tensor sphere(const torch::Tensor& p, double radius, std::array<double, 3> centre) {
  const auto c = torch::tensor({centre[0], centre[1], centre[2]}, torch::kFloat32);
  return radius - (p - c).norm(2, 1);
}

// A torus about the y axis in the plane y = y0: ring radius R, tube radius r.
torch::Tensor torus(const torch::Tensor& p, double R, double r, double y0) {
  const auto ring = torch::sqrt(p.select(1, 0).square() + p.select(1, 2).square()) - R;
  return r - torch::sqrt(ring.square() + (p.select(1, 1) - y0).square());
}

struct Counted {
  ScalarField field;
  int64_t calls = 0, points = 0;
  ScalarField counting() {
    return [this](const torch::Tensor& p) {
      ++calls;
      points += p.size(0);
      return field(p);
    };
  }
};

// MISE 16 -> 64 over [-1, 1]^3 against marching cubes on the densely sampled final grid.
void expect_same_as_dense(const ScalarField& field, double max_fraction, int64_t components) {
  Counted counted{field};
  const auto result = mise(counted.counting(), {-1, -1, -1}, {1, 1, 1}, MiseOptions::resolutions(16, 64));
  EXPECT_EQ(result.stats.dims, (std::array<int64_t, 3>{65, 65, 65}));
  EXPECT_EQ(result.stats.points_evaluated, counted.points);  // no sample evaluated twice
  EXPECT_EQ(result.stats.evaluated_per_level.size(), 3u);
  EXPECT_EQ(result.stats.evaluated_per_level[0], 17 * 17 * 17);
  EXPECT_LT(result.stats.evaluated_fraction(), max_fraction);
  const auto dense = iso_surface(field, result.box, result.stats.dims);
  ASSERT_GT(dense.num_faces(), 0);
  // Every cell the surface crosses was refined down to the final grid, so the
  // meshes are identical, not just close.
  EXPECT_TRUE(torch::equal(result.mesh.vertices, dense.vertices))
      << result.mesh.num_vertices() << " vs " << dense.num_vertices() << " vertices";
  EXPECT_TRUE(torch::equal(result.mesh.faces, dense.faces));
  EXPECT_TRUE(is_closed_manifold(result.mesh));
  EXPECT_EQ(connected_components(result.mesh).count, components);
}

TEST(Mise, SphereEqualsDenseExtractionWithFewerEvaluations) {
  expect_same_as_dense([](const torch::Tensor& p) { return sphere(p, 0.7, {0.05, -0.1, 0.02}); }, 0.25, 1);
}

TEST(Mise, TwoSeparatedSpheres) {
  expect_same_as_dense(
      [](const torch::Tensor& p) {
        return torch::maximum(sphere(p, 0.35, {-0.5, 0, 0}), sphere(p, 0.25, {0.55, 0.2, -0.1}));
      },
      0.2, 2);
}

TEST(Mise, ThinTorusKeepsItsTopology) {
  // Tube diameter 0.14, its plane half a coarse cell (0.125) off the coarse
  // samples: only a few coarse samples fall inside the tube, and some coarse
  // cells the tube crosses have no corner inside. Splitting the neighbours of
  // active coarse cells recovers the whole ring.
  const ScalarField field = [](const torch::Tensor& p) { return torus(p, 0.6, 0.07, 0.0625); };
  expect_same_as_dense(field, 0.1, 1);
  auto options = MiseOptions::resolutions(16, 64);
  const auto result = mise(field, {-1, -1, -1}, {1, 1, 1}, options);
  EXPECT_EQ(analyze_topology(result.mesh).euler_characteristic(), 0);  // genus 1
  // Without the neighbours (ONet's rule) the ring breaks into pieces.
  options.dilated_levels = 0;
  EXPECT_GT(connected_components(mise(field, {-1, -1, -1}, {1, 1, 1}, options).mesh).count, 1);
}

TEST(Mise, NonCubicBoxGetsCubicVoxelsCoveringIt) {
  const ScalarField field = [](const torch::Tensor& p) { return sphere(p, 0.2, {0.1, 0.5, 0.0}); };
  MiseOptions options = MiseOptions::resolutions(8, 32);
  const auto result = mise(field, {-0.25, -0.1, -0.3}, {0.35, 1.0, 0.3}, options);
  // Longest side y: 1.1 m in 8 coarse cells; x and z need 5 and 5 of them.
  EXPECT_EQ(result.stats.dims, (std::array<int64_t, 3>{5 * 4 + 1, 8 * 4 + 1, 5 * 4 + 1}));
  for (int axis = 0; axis < 3; ++axis) EXPECT_NEAR(result.box.voxel_size[axis], 1.1 / 32, 1e-12);
  const double lo[3] = {-0.25, -0.1, -0.3}, hi[3] = {0.35, 1.0, 0.3};
  const int64_t samples[3] = {result.stats.dims[2], result.stats.dims[1], result.stats.dims[0]};
  for (int axis = 0; axis < 3; ++axis) {
    const double first = result.box.origin[axis];
    const double last = first + static_cast<double>(samples[axis] - 1) * result.box.voxel_size[axis];
    EXPECT_LE(first, lo[axis] + 1e-9);
    EXPECT_GE(last, hi[axis] - 1e-9);
    EXPECT_NEAR(0.5 * (first + last), 0.5 * (lo[axis] + hi[axis]), 1e-9);
  }
  const double r = 0.2, volume = 4.0 / 3.0 * M_PI * r * r * r;
  EXPECT_NEAR(signed_volume(result.mesh), volume, 0.03 * volume);
}

TEST(Mise, NoUpsamplingIsDenseSampling) {
  const ScalarField field = [](const torch::Tensor& p) { return sphere(p, 0.5, {0, 0, 0}); };
  MiseOptions options = MiseOptions::resolutions(20, 20);
  options.batch_size = 1000;
  Counted counted{field};
  const auto result = mise(counted.counting(), {-1, -1, -1}, {1, 1, 1}, options);
  EXPECT_EQ(result.stats.points_evaluated, 21 * 21 * 21);
  EXPECT_EQ(counted.calls, (21 * 21 * 21 + 999) / 1000);
  EXPECT_TRUE(torch::equal(result.values, sample_grid(field, result.box, {21, 21, 21})));
}

TEST(Mise, ProgressReportsEveryLevel) {
  std::vector<int64_t> levels, totals;
  mise([](const torch::Tensor& p) { return sphere(p, 0.5, {0, 0, 0}); }, {-1, -1, -1}, {1, 1, 1},
       MiseOptions::resolutions(4, 32), [&](int64_t level, int64_t count, int64_t points) {
         levels.push_back(level);
         totals.push_back(points);
         EXPECT_EQ(count, 4);
       });
  EXPECT_EQ(levels, (std::vector<int64_t>{0, 1, 2, 3}));
  EXPECT_TRUE(std::is_sorted(totals.begin(), totals.end()));
}

TEST(Mise, RejectsBadOptionsAndFields) {
  testing::expect_error([] { MiseOptions::resolutions(32, 200); }, {"power of two", "200"});
  testing::expect_error([] { MiseOptions::resolutions(64, 32); }, {"at least"});
  const ScalarField field = [](const torch::Tensor& p) { return sphere(p, 0.5, {0, 0, 0}); };
  testing::expect_error([&] { mise(field, {0, 0, 0}, {1, 0, 1}); }, {"axis 1"});
  MiseOptions bad;
  bad.batch_size = 0;
  testing::expect_error([&] { mise(field, {0, 0, 0}, {1, 1, 1}, bad); }, {"batch size"});
  testing::expect_error(
      [] { mise([](const torch::Tensor&) { return torch::zeros({3}); }, {0, 0, 0}, {1, 1, 1}); },
      {"returned 3 values"});
}

}  // namespace
}  // namespace fskin
