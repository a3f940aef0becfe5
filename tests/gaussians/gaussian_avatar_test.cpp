// Articulated Gaussians: forward skinning of Gaussians against LBS of the
// mesh they sit on, a rigid motion of the body against the same motion of the
// camera, spherical harmonics, and replacing the Gaussians.
#include "fskin/gaussians/gaussian_avatar.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <Eigen/Geometry>

#include <string>

#include "fskin/data/point_sampling.h"
#include "fskin/data/random.h"
#include "fskin/gaussians/spherical_harmonics.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/skeleton/rotations.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

GaussianAvatarOptions small_options(int64_t gaussians, int64_t sh_degree) {
  GaussianAvatarOptions o;
  o.initial_gaussians = gaussians;
  o.sh_degree = sh_degree;
  o.skinning_grid_resolution = 48;
  return o;
}

TEST(GaussianAvatar, GaussiansOnTheVerticesFollowTheMeshsLinearBlendSkinning) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  const auto& character = dataset.character();
  const auto split = dataset.load_split("train");
  for (const std::string source : {"surface", "grid"}) {
    auto options = small_options(100, 0);
    options.skinning_source = source;
    GaussianAvatar avatar(character, options, 0);
    const auto vertices = character.mesh.vertices.to(torch::kFloat32);
    const int64_t n = vertices.size(0);
    // The surface source: each Gaussian carries its vertex's own weights.
    const auto weights = source == "surface" ? character.weights.to(torch::kFloat32) : torch::zeros({n, 0});
    avatar->replace_gaussians(vertices, torch::zeros({n, 3}),
                              torch::tensor({1.0f, 0.0f, 0.0f, 0.0f}).repeat({n, 1}), torch::zeros({n}),
                              torch::zeros({n, 1, 3}), torch::zeros({n, 0, 3}), weights, torch::zeros({n, 0}),
                              torch::zeros({n, 0}));
    EXPECT_EQ(avatar->size(), n);
    const auto height = (vertices.select(1, 1).max() - vertices.select(1, 1).min()).item<double>();
    for (int64_t frame = 0; frame < split.size(); ++frame) {
      const auto bones = split.bone_transforms[frame];
      torch::NoGradGuard no_grad;
      const auto posed = avatar->pose(bones);
      const auto expected = linear_blend_skinning(vertices.unsqueeze(0), character.weights.to(torch::kFloat32),
                                                  bones.unsqueeze(0))[0];
      const auto distance = (posed.means - expected).norm(2, 1);
      if (source == "surface") {
        EXPECT_LT(distance.max().item<double>(), 1e-5 * height) << "frame " << frame;
      } else {
        // The grid's weights are the mesh's at the surface up to trilinear
        // interpolation: vertices land within a small share of the height.
        EXPECT_LT(distance.mean().item<double>(), 0.002 * height) << "frame " << frame;
        EXPECT_LT(distance.max().item<double>(), 0.03 * height) << "frame " << frame;
      }
    }
  }
}

TEST(GaussianAvatar, SurfaceWeightsInterpolateTheVertexWeightsAtEachSample) {
  // Weights that encode each vertex's position (affine in it): interpolated
  // barycentrically at a point of a face, they encode that point.
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  RiggedMesh character = dataset.character();
  const auto v = character.mesh.vertices.to(torch::kFloat64);
  const auto low = std::get<0>(v.min(0)), extent = std::get<0>(v.max(0)) - low;
  const auto q = (v - low) / extent * 0.25;  // [V, 3] in [0, 0.25]
  auto weights = torch::zeros({v.size(0), character.num_joints()}, torch::kFloat64);
  weights.narrow(1, 0, 3).copy_(q);
  weights.select(1, 3).copy_(1 - q.sum(1));
  character.weights = weights;
  GaussianAvatar avatar(character, small_options(2000, 0), 5);
  const auto w = avatar->skinning_weights().to(torch::kFloat64);
  const auto recovered = low + w.narrow(1, 0, 3) * 4 * extent;
  const double size = extent.max().item<double>();
  EXPECT_LT((recovered - avatar->means().to(torch::kFloat64)).abs().max().item<double>(), 1e-4 * size);
  EXPECT_TRUE(torch::allclose(w.sum(1), torch::ones({2000}, torch::kFloat64), 1e-5, 1e-5));
}

TEST(GaussianAvatar, LearnedCorrectionsStartAtTheRigsWeightsAndMoveThemDifferentiably) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  const auto& character = dataset.character();
  auto options = small_options(300, 0);
  GaussianAvatar rig(character, options, 4);
  options.learned_skinning = true;
  GaussianAvatar learned(character, options, 4);
  ASSERT_EQ(learned->skinning_corrections().sizes(), (std::vector<int64_t>{300, character.num_joints()}));
  EXPECT_EQ(rig->skinning_corrections().size(1), 0);
  // Zero corrections: the rig's weights (up to the 1e-6 floor).
  EXPECT_LT((learned->skinning_weights() - rig->skinning_weights()).abs().max().item<double>(), 1e-4);
  // A correction towards bone 0 raises its weight, and the gradient reaches the corrections.
  {
    torch::NoGradGuard no_grad;
    learned->skinning_corrections().select(1, 0).fill_(3.0f);
  }
  const auto weights = learned->skinning_weights();
  EXPECT_TRUE(torch::allclose(weights.sum(1), torch::ones({300}), 1e-5, 1e-5));
  EXPECT_TRUE((weights.select(1, 0) >= rig->skinning_weights().select(1, 0) - 1e-6).all().item<bool>());
  const auto posed = learned->pose(dataset.load_split("train").bone_transforms[0]);
  posed.means.sum().backward();
  ASSERT_TRUE(learned->skinning_corrections().grad().defined());
  EXPECT_GT(learned->skinning_corrections().grad().abs().sum().item<double>(), 0.0);
}

TEST(GaussianAvatar, MovingTheBodyRigidlyRendersAsMovingTheCameraTheOtherWay) {
  // Every bone moved by one rigid transform M: the posed Gaussians are the
  // canonical ones moved by M, so a camera E sees what the camera E M sees of
  // the unposed body, view-dependent colour included.
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  const auto& character = dataset.character();
  const auto split = dataset.load_split("train");
  GaussianAvatar avatar(character, small_options(3000, 2), 1);
  torch::manual_seed(0);
  {
    torch::NoGradGuard no_grad;
    avatar->sh_dc().normal_(0, 0.4);
    avatar->sh_rest().normal_(0, 0.4);
    avatar->log_scales().add_(torch::randn_like(avatar->log_scales()) * 0.3);
    avatar->rotations().normal_();
  }
  Eigen::Matrix4d motion = Eigen::Matrix4d::Identity();
  motion.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 1, -0.3).normalized()).toRotationMatrix();
  motion.topRightCorner<3, 1>() = Eigen::Vector3d(0.05, -0.1, 0.2);
  const int64_t joints = character.num_joints();
  auto moved = torch::empty({4, 4}, torch::kFloat64);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) moved[i][j] = motion(i, j);
  const auto bones = moved.to(torch::kFloat32).expand({joints, 4, 4}).contiguous();
  const auto identity = torch::eye(4).expand({joints, 4, 4}).contiguous();
  const PinholeCamera camera = split.cameras[0];
  PinholeCamera moved_camera = camera;
  moved_camera.extrinsic = camera.extrinsic * motion;
  torch::NoGradGuard no_grad;
  const auto a = avatar->render(bones, camera, {1, 1, 1});
  const auto b = avatar->render(identity, moved_camera, {1, 1, 1});
  EXPECT_GT(a.alpha.sum().item<double>(), 100.0);  // the body is in the picture
  EXPECT_LT((a.image - b.image).abs().max().item<double>(), 2e-3);
  EXPECT_LT((a.alpha - b.alpha).abs().max().item<double>(), 2e-3);
}

TEST(GaussianAvatar, SphericalHarmonicsOfDegreeZeroGiveTheirColourAndHigherDegreesVaryWithTheView) {
  const auto color = torch::tensor({0.2f, 0.5f, 0.9f}).view({1, 3});
  auto coefficients = torch::zeros({1, 4, 3});
  coefficients.select(1, 0) = color_to_spherical_harmonics_dc(color);
  const auto forward = torch::tensor({0.0f, 0.0f, 1.0f}).view({1, 3});
  EXPECT_TRUE(torch::allclose(spherical_harmonics_color(coefficients, forward), color, 1e-6, 1e-6));
  coefficients.select(1, 2).fill_(0.3f);  // the z-linear term
  const auto front = spherical_harmonics_color(coefficients, forward);
  const auto back = spherical_harmonics_color(coefficients, -forward);
  EXPECT_TRUE(torch::allclose(front - color, color - back, 1e-6, 1e-6));
  EXPECT_NEAR((front - color)[0][0].item<float>(), 0.3f * 0.4886025f, 1e-6);
  testing::expect_error([&] { spherical_harmonics_color(torch::zeros({1, 5, 3}), forward); }, {"5 coefficients"});
}

TEST(GaussianAvatar, ThinStartsAreDiscsInTheirFacesPlanes) {
  // The avatar samples its Gaussians as sample_surface_with_faces does with
  // its seed: each one's thin axis (rotation's third column) is its face's
  // normal, the other two span the face, and the thin scale is the width
  // times initial_thickness.
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  const auto& character = dataset.character();
  auto options = small_options(1500, 0);
  options.initial_thickness = 0.1;
  GaussianAvatar avatar(character, options, 7);
  Rng rng(7);
  const auto samples = sample_surface_with_faces(character.mesh, 1500, rng);
  ASSERT_TRUE(torch::allclose(avatar->means(), samples.points.to(torch::kFloat32)));
  const auto v = character.mesh.vertices.to(torch::kFloat64);
  const auto corners = character.mesh.faces.index_select(0, samples.faces);
  const auto a = v.index_select(0, corners.select(1, 0));
  const auto normal = torch::cross(v.index_select(0, corners.select(1, 1)) - a, v.index_select(0, corners.select(1, 2)) - a, 1);
  const auto unit_normal = normal / normal.norm(2, 1, true);
  const auto q = avatar->rotations().to(torch::kFloat64);
  const auto r = quaternion_to_matrix(q / q.norm(2, 1, true));
  const auto thin_axis = r.select(2, 2);
  EXPECT_GT((thin_axis * unit_normal).sum(1).abs().min().item<double>(), 1 - 1e-5);
  EXPECT_LT((r.select(2, 0) * unit_normal).sum(1).abs().max().item<double>(), 1e-5);
  EXPECT_LT((r.select(2, 1) * unit_normal).sum(1).abs().max().item<double>(), 1e-5);
  const auto scales = torch::exp(avatar->log_scales().to(torch::kFloat64));
  EXPECT_TRUE(torch::allclose(scales.select(1, 2), 0.1 * scales.select(1, 0), 1e-5));
  EXPECT_TRUE(torch::allclose(scales.select(1, 1), scales.select(1, 0)));
  // Spheres with thickness 1.
  auto sphere_options = small_options(100, 0);
  sphere_options.initial_thickness = 1;
  GaussianAvatar spheres(character, sphere_options, 7);
  EXPECT_TRUE(torch::equal(spheres->log_scales().select(1, 0), spheres->log_scales().select(1, 2)));
  options.initial_thickness = 0;
  testing::expect_error([&] { GaussianAvatar(character, options, 0); }, {"initial_thickness"});
}

TEST(GaussianAvatar, TheNonRigidOffsetStartsAtZeroLearnsAndIgnoresRigidMotionsOfTheBody) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  const auto split = dataset.load_split("train");
  auto options = small_options(400, 0);
  options.non_rigid = true;
  GaussianAvatar moving(dataset.character(), options, 5);
  GaussianAvatar rigid(dataset.character(), small_options(400, 0), 5);
  const auto bones = split.bone_transforms[0];
  const auto& camera = split.cameras[0];
  // Zero at the start: the same picture as without it.
  const auto start = moving->render(bones, camera, {1, 1, 1});
  EXPECT_EQ(start.offsets.abs().max().item<double>(), 0.0);
  EXPECT_TRUE(torch::equal(start.image, rigid->render(bones, camera, {1, 1, 1}).image));
  EXPECT_FALSE(rigid->render(bones, camera, {1, 1, 1}).offsets.defined());
  // The picture's gradient reaches the network's last layer; a step makes the offsets pose-dependent.
  start.image.sum().backward();
  auto parameters = moving->non_rigid_offset()->parameters();
  double gradient = 0;
  for (const auto& p : parameters)
    if (p.grad().defined()) gradient += p.grad().abs().sum().item<double>();
  EXPECT_GT(gradient, 0.0);
  {
    torch::NoGradGuard no_grad;
    for (auto& p : parameters) p.add_(torch::randn_like(p) * 0.05);
  }
  torch::NoGradGuard no_grad;
  const auto offsets = moving->pose(bones).offsets;
  EXPECT_GT(offsets.abs().max().item<double>(), 0.0);
  const auto other_pose = dataset.load_split("novel_pose").bone_transforms[0];
  EXPECT_GT((moving->pose(other_pose).offsets - offsets).abs().max().item<double>(), 1e-4);
  // A rotation and shift of the whole body (every bone) changes nothing.
  Eigen::Matrix4f g = Eigen::Matrix4f::Identity();
  g.topLeftCorner<3, 3>() = Eigen::AngleAxisf(0.7f, Eigen::Vector3f(0.2f, 1, 0.3f).normalized()).toRotationMatrix();
  g.topRightCorner<3, 1>() = Eigen::Vector3f(0.3f, -0.1f, 0.5f);
  auto moved = torch::empty({4, 4});
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) moved[r][c] = g(r, c);
  const auto turned = torch::matmul(moved.unsqueeze(0), bones);
  EXPECT_LT((moving->pose(turned).offsets - offsets).abs().max().item<double>(), 1e-5);
}

TEST(GaussianAvatar, StartsOnTheSurfaceAndRejectsBadOptions) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  const auto& character = dataset.character();
  GaussianAvatar avatar(character, small_options(500, 1), 2);
  EXPECT_EQ(avatar->size(), 500);
  EXPECT_EQ(avatar->sh().size(1), 4);
  const auto weights = avatar->skinning_weights();
  EXPECT_TRUE(torch::allclose(weights.sum(1), torch::ones({500}), 1e-4, 1e-4));
  // Same seed, same Gaussians.
  GaussianAvatar again(character, small_options(500, 1), 2);
  EXPECT_TRUE(torch::equal(avatar->means(), again->means()));
  auto bad = small_options(10, 4);
  testing::expect_error([&] { GaussianAvatar(character, bad, 0); }, {"sh_degree", "0 to 3"});
  auto bad_source = small_options(10, 1);
  bad_source.skinning_source = "mesh";
  testing::expect_error([&] { GaussianAvatar(character, bad_source, 0); }, {"skinning source", "\"mesh\""});
}

}  // namespace
}  // namespace fskin
