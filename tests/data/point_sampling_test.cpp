#include "fskin/data/point_sampling.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "data/analytic_meshes.h"
#include "test_util.h"

namespace fskin {
namespace {

TEST(PointSampling, SurfaceSamplesAreAreaUniform) {
  // Box 1 x 2 x 4: faces normal to x, y, z have areas 8, 4, 2 (twice each).
  const auto mesh = testing::box_mesh({0, 0, 0}, {1, 2, 4});
  Rng rng(1);
  const auto p = sample_surface(mesh, 70000, rng);
  const auto on = [&](int axis, float value) {
    return (p.select(1, axis) - value).abs().lt(1e-5).sum().item<int64_t>() / 70000.0;
  };
  EXPECT_NEAR(on(0, 0) + on(0, 1), 16.0 / 28.0, 0.01);
  EXPECT_NEAR(on(1, 0) + on(1, 2), 8.0 / 28.0, 0.01);
  EXPECT_NEAR(on(2, 0) + on(2, 4), 4.0 / 28.0, 0.01);
  // Within a face, uniform: the mean of the x = 0 face's samples is its centre.
  const auto face = p.index({p.select(1, 0).abs() < 1e-5});
  EXPECT_NEAR(face.select(1, 1).mean().item<float>(), 1.0f, 0.02f);
  EXPECT_NEAR(face.select(1, 2).mean().item<float>(), 2.0f, 0.04f);
}

TEST(PointSampling, SurfaceSamplesNameTheirFaceAndWhereOnIt) {
  const auto mesh = testing::sphere_mesh(1.0, 8, 16);
  Rng rng(3);
  const auto samples = sample_surface_with_faces(mesh, 500, rng);
  Rng again(3);
  EXPECT_TRUE(torch::equal(samples.points, sample_surface(mesh, 500, again)));  // the same draws
  const auto b = samples.barycentrics;
  EXPECT_GE(b.min().item<double>(), 0.0);
  EXPECT_TRUE(torch::allclose(b.sum(1), torch::ones({500}, torch::kFloat64)));
  const auto corners = mesh.faces.index_select(0, samples.faces);
  const auto v = mesh.vertices.to(torch::kFloat64);
  auto rebuilt = torch::zeros({500, 3}, torch::kFloat64);
  for (int k = 0; k < 3; ++k) rebuilt += b.select(1, k).unsqueeze(1) * v.index_select(0, corners.select(1, k));
  EXPECT_LT((rebuilt - samples.points.to(torch::kFloat64)).abs().max().item<double>(), 1e-6);
}

TEST(PointSampling, FramePointsHaveUniformHalfInTheBoxAndNoisySurfaceHalf) {
  const auto mesh = testing::sphere_mesh(1.0, 64, 128);
  SamplingOptions options;
  options.uniform_points = 20000;
  options.surface_points = 30000;
  options.noise_sigma = 0.02;
  Rng rng(5);
  const auto points = sample_frame_points(mesh, options, rng);
  ASSERT_EQ(points.sizes(), (std::vector<int64_t>{50000, 3}));
  const auto uniform = points.slice(0, 0, 20000), surface = points.slice(0, 20000);
  EXPECT_LE(uniform.abs().max().item<float>(), 1.1f + 1e-5f);
  EXPECT_GT(uniform.abs().max().item<float>(), 1.09f);  // the box is enlarged 10%
  const auto radial = surface.norm(2, 1) - 1.0;
  EXPECT_NEAR(radial.mean().item<float>(), 0.0f, 0.002f);
  EXPECT_NEAR(radial.std().item<float>(), 0.02f, 0.001f);
  const Box box = mesh_bounds(mesh, 1.1);
  EXPECT_NEAR(box.max[1], 1.1, 1e-6);
  EXPECT_NEAR(box.min[0], -1.1, 1e-3);
}

TEST(PointSampling, SameSeedSamePointsOtherSeedOtherPoints) {
  const auto mesh = testing::capsule_mesh(0.2, 0.3, 16, 32);
  SamplingOptions options;
  options.uniform_points = 500;
  options.surface_points = 500;
  Rng a(9), b(9), c(10);
  const auto pa = sample_frame_points(mesh, options, a);
  EXPECT_TRUE(torch::equal(pa, sample_frame_points(mesh, options, b)));
  EXPECT_FALSE(torch::equal(pa, sample_frame_points(mesh, options, c)));
}

TEST(PointSampling, AShareOfTheSurfacePointsGoesToTheEmphasisedFaces) {
  // Box 1 x 2 x 4: faces normal to x, y, z have areas 8, 4, 2 (twice each).
  const auto mesh = testing::box_mesh({0, 0, 0}, {1, 2, 4});
  SamplingOptions options;
  options.uniform_points = 100;
  options.surface_points = 20000;
  options.noise_sigma = 0;
  Rng a(3), b(3), c(3);
  // Share 0 draws exactly what the plain sampler draws.
  EXPECT_TRUE(torch::equal(sample_frame_points(mesh, options, a),
                           sample_frame_points(mesh, options, b, torch::tensor({0, 1}, torch::kInt64), 0.0)));
  // Half of them on the x = 0 face (area 8 of 28), plus its area share of the rest.
  const auto face_x = mesh.vertices.select(1, 0).index_select(0, mesh.faces.reshape({-1})).reshape({-1, 3});
  const auto faces = (face_x.abs().amax(1) < 1e-9).nonzero().reshape({-1});
  ASSERT_EQ(faces.size(0), 2);
  const auto points = sample_frame_points(mesh, options, c, faces, 0.5).slice(0, 100);
  const double on_face = (points.select(1, 0).abs() < 1e-5).sum().item<double>() / 20000.0;
  EXPECT_NEAR(on_face, 0.5 + 0.5 * 8.0 / 28.0, 0.015);
  testing::expect_error([&] { sample_frame_points(mesh, options, c, faces, 1.5); }, {"emphasised share"});
}

TEST(PointSampling, RejectsBadOptions) {
  SamplingOptions options;
  options.box_scale = 0.5;
  testing::expect_error([&] { options.validate(); }, {"box scale"});
  options = {};
  options.uniform_points = options.surface_points = 0;
  testing::expect_error([&] { options.validate(); }, {"point counts"});
}

}  // namespace
}  // namespace fskin
