#include "fskin/data/inside_test.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "data/analytic_meshes.h"
#include "test_util.h"
#include "fskin/core/error.h"
#include "fskin/data/point_sampling.h"
#include "fskin/geometry/mesh_topology.h"

namespace fskin {
namespace {

using testing::box_mesh;
using testing::capsule_mesh;
using testing::sphere_mesh;

// Agreement of InsideTest with an analytic signed distance (negative inside)
// on 100k points uniform in `box`: overall, and for points farther than
// `margin` from the surface.
struct Agreement {
  double overall = 0, away = 0;
};

Agreement agreement(const Mesh& mesh, const Box& box,
                    const std::function<torch::Tensor(const torch::Tensor&)>& signed_distance,
                    double margin) {
  Rng rng(42);
  const auto points = sample_box(box, 100000, rng);
  const auto occupancy = InsideTest(mesh).contains(points).to(torch::kBool);
  const auto d = signed_distance(points);
  const auto truth = d < 0;
  const auto equal = occupancy == truth;
  const auto away = d.abs() > margin;
  Agreement a;
  a.overall = equal.to(torch::kFloat64).mean().item<double>();
  a.away = equal.index({away}).to(torch::kFloat64).mean().item<double>();
  return a;
}

class InsideTestShapes : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  }
};

TEST_F(InsideTestShapes, SphereMatchesAnalyticOccupancy) {
  const auto mesh = sphere_mesh(0.5);
  ASSERT_GT(signed_volume(mesh), 0.0);
  const auto a = agreement(mesh, {{-0.6, -0.6, -0.6}, {0.6, 0.6, 0.6}},
                           [](const torch::Tensor& p) { return p.norm(2, 1) - 0.5; }, 0.005);
  EXPECT_GE(a.overall, 0.999);
  EXPECT_EQ(a.away, 1.0);
}

TEST_F(InsideTestShapes, CapsuleMatchesAnalyticOccupancy) {
  const auto mesh = capsule_mesh(0.2, 0.4);
  ASSERT_GT(signed_volume(mesh), 0.0);
  ASSERT_TRUE(is_closed_manifold(mesh));
  const auto a = agreement(mesh, {{-0.3, -0.7, -0.3}, {0.3, 0.7, 0.3}},
                           [](const torch::Tensor& p) {
                             const auto y = p.select(1, 1).clamp(-0.4, 0.4);
                             auto axis = torch::zeros_like(p);
                             axis.select(1, 1).copy_(y);
                             return (p - axis).norm(2, 1) - 0.2;
                           },
                           0.005);
  EXPECT_GE(a.overall, 0.999);
  EXPECT_EQ(a.away, 1.0);
}

TEST_F(InsideTestShapes, BoxMatchesAnalyticOccupancy) {
  const auto mesh = box_mesh({-0.3f, -0.2f, -0.1f}, {0.3f, 0.2f, 0.1f});
  ASSERT_GT(signed_volume(mesh), 0.0);
  const auto half = torch::tensor({0.3f, 0.2f, 0.1f});
  const auto a = agreement(mesh, {{-0.4, -0.3, -0.2}, {0.4, 0.3, 0.2}},
                           [&](const torch::Tensor& p) {
                             return std::get<0>((p.abs() - half).max(1));  // < 0 inside
                           },
                           1e-4);
  EXPECT_GE(a.overall, 0.999);
  EXPECT_EQ(a.away, 1.0);
}

TEST_F(InsideTestShapes, OverlappingClosedPartsGiveTheirUnion) {
  // Two spheres overlapping around the origin, as one mesh without boolean
  // clean-up (like limbs of a game character). Parity would call the overlap
  // outside; the winding number counts it twice inside.
  const auto mesh = testing::merge_meshes(testing::translated(sphere_mesh(0.3, 48, 96), -0.2f, 0, 0),
                                          testing::translated(sphere_mesh(0.3, 48, 96), 0.2f, 0, 0));
  const auto points = torch::tensor({0.0f, 0.0f, 0.0f, 0.05f, 0.1f, 0.0f, -0.3f, 0.0f, 0.1f,
                                     0.0f, 0.35f, 0.0f, 0.55f, 0.0f, 0.0f})
                          .reshape({5, 3});
  const auto occupancy = InsideTest(mesh).contains(points);
  EXPECT_TRUE(torch::equal(occupancy, torch::tensor({1, 1, 1, 0, 0}, torch::kUInt8)));
}

TEST_F(InsideTestShapes, SphereWithAHoleKeepsInsideAndOutside) {
  // Remove the faces of the top cap (y > 0.85 r): a hole of radius ~0.53 r.
  const auto closed = sphere_mesh(0.5, 64, 128);
  const auto centres = closed.vertices.index_select(0, closed.faces.flatten())
                           .reshape({-1, 3, 3})
                           .mean(1);
  Mesh open{closed.vertices, closed.faces.index({centres.select(1, 1) < 0.425}), {}};
  ASSERT_GT(analyze_topology(open).boundary_edges, 0);
  const auto a = agreement(open, {{-0.6, -0.6, -0.6}, {0.6, 0.6, 0.6}},
                           [](const torch::Tensor& p) { return p.norm(2, 1) - 0.5; }, 0.02);
  EXPECT_GE(a.overall, 0.995);
  EXPECT_GE(a.away, 0.997);
  // Deep inside and far outside never flip, even right under and over the hole.
  const auto points = torch::tensor({0.0f, 0.0f, 0.0f, 0.0f, 0.3f, 0.0f, 0.1f, -0.3f, 0.1f,
                                     0.0f, 0.9f, 0.0f, 0.0f, -0.9f, 0.0f, 0.8f, 0.0f, 0.0f})
                          .reshape({6, 3});
  EXPECT_TRUE(torch::equal(InsideTest(open).contains(points),
                           torch::tensor({1, 1, 1, 0, 0, 0}, torch::kUInt8)));
}

TEST_F(InsideTestShapes, InsideOutMeshStillCountsInside) {
  auto mesh = sphere_mesh(0.5, 32, 64);
  mesh.faces = mesh.faces.flip(1);
  const auto points = torch::tensor({0.0f, 0.0f, 0.0f, 0.7f, 0.0f, 0.0f}).reshape({2, 3});
  EXPECT_TRUE(torch::equal(InsideTest(mesh).contains(points), torch::tensor({1, 0}, torch::kUInt8)));
}

TEST(InsideTest, RejectsBadInput) {
  if (!inside_test_available()) {
    testing::expect_error([] { InsideTest(box_mesh({0, 0, 0}, {1, 1, 1})); }, {"Embree"});
    return;
  }
  InsideTest test(box_mesh({0, 0, 0}, {1, 1, 1}));
  testing::expect_error([&] { test.contains(torch::zeros({4, 2})); }, {"InsideTest points"});
}

}  // namespace
}  // namespace fskin
