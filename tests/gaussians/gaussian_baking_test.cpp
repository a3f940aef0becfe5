// Baking a Gaussian avatar into its character's mesh: colours of a known
// field come back at the vertices, a covering layer hides the one beneath,
// uncovered points take their nearest Gaussian's colour, and the mesh keeps
// the rig's weights (or blends the learned ones).
#include "fskin/gaussians/gaussian_baking.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <array>
#include <cstdlib>
#include <string>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/geometry/mesh_subdivision.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/gaussians/spherical_harmonics.h"
#include "fskin/util/atomic_file.h"
#include "radiance/tiny_image_dataset.h"
#include "test_util.h"

namespace fskin {
namespace {

const RiggedMesh& character() {
  static const ImageDataset dataset(testing::tiny_image_dataset().dir);
  return dataset.character();
}

GaussianAvatar avatar_of(int64_t gaussians, bool anchored = false, bool learned = false) {
  GaussianAvatarOptions options;
  options.initial_gaussians = gaussians;
  options.anchored = anchored;
  options.learned_skinning = learned;
  return GaussianAvatar(character(), options, 0);
}

// A smooth colour field over the character's box, in [0.1, 0.9].
torch::Tensor field(const torch::Tensor& points) {
  const auto v = character().mesh.vertices.to(torch::kFloat32);
  const auto lo = std::get<0>(v.min(0)), hi = std::get<0>(v.max(0));
  return 0.1 + 0.8 * (points - lo) / (hi - lo);
}

void paint(GaussianAvatarImpl& avatar, const torch::Tensor& colors, double opacity_logit) {
  torch::NoGradGuard no_grad;
  avatar.sh_dc().copy_(color_to_spherical_harmonics_dc(colors).unsqueeze(1));
  avatar.opacity_logits().fill_(opacity_logit);
}

TEST(GaussianBaking, AColourFieldComesBackAtTheVertices) {
  auto avatar = avatar_of(4000);
  paint(*avatar, field(avatar->means().detach()), 4.0);
  const auto& mesh = character().mesh;
  const auto baked = bake_gaussians_at(*avatar, mesh.vertices, vertex_normals(mesh));
  ASSERT_EQ(baked.colors.sizes(), (std::vector<int64_t>{mesh.num_vertices(), 3}));
  EXPECT_FALSE(baked.weights.defined());
  const double error = (baked.colors - field(mesh.vertices.to(torch::kFloat32))).abs().mean().item<double>();
  EXPECT_LT(error, 0.02);
  EXPECT_GT(baked.coverage.median().item<double>(), 0.9);
}

TEST(GaussianBaking, ACoveringLayerHidesTheOneBeneath) {
  auto avatar = avatar_of(3000, /*anchored=*/true);
  // The same Gaussians twice: red ones where they were sampled, blue ones two
  // spacings deeper along their faces' normals.
  const int64_t n = avatar->size();
  const auto normals = avatar->surface_anchors().narrow(1, 3, 3);
  const auto deeper = avatar->means().detach() - 2 * avatar->initial_spacing() * normals;
  const auto twice = [](const torch::Tensor& t) { return torch::cat({t.detach(), t.detach()}); };
  const auto red = torch::tensor({0.9f, 0.1f, 0.1f}).expand({n, 3});
  const auto blue = torch::tensor({0.1f, 0.1f, 0.9f}).expand({n, 3});
  avatar->replace_gaussians(torch::cat({avatar->means().detach(), deeper}), twice(avatar->log_scales()),
                            twice(avatar->rotations()), torch::full({2 * n}, 4.0f),
                            color_to_spherical_harmonics_dc(torch::cat({red, blue})).unsqueeze(1),
                            twice(avatar->sh_rest()), twice(avatar->surface_weights()),
                            twice(avatar->skinning_corrections()), twice(avatar->surface_anchors()));
  const auto& mesh = character().mesh;
  const auto colors = bake_gaussians_at(*avatar, mesh.vertices, vertex_normals(mesh)).colors;
  // Red over blue almost everywhere: the red channel's median above 0.8, the blue's below 0.2.
  EXPECT_GT(colors.select(1, 0).median().item<double>(), 0.8);
  EXPECT_LT(colors.select(1, 2).median().item<double>(), 0.2);
}

TEST(GaussianBaking, UncoveredPointsAndPointsWithoutANormalTakeTheirNearestGaussiansColour) {
  auto avatar = avatar_of(500);
  const auto colors = torch::rand({500, 3});
  paint(*avatar, colors, -10.0);  // opacity 4.5e-5: under the rasteriser's 1/255 everywhere
  const auto& mesh = character().mesh;
  const auto baked = bake_gaussians_at(*avatar, mesh.vertices, vertex_normals(mesh));
  EXPECT_EQ(baked.coverage.max().item<float>(), 0.0f);
  const auto nearest = torch::cdist(mesh.vertices.to(torch::kFloat32), avatar->means().detach()).argmin(1);
  EXPECT_TRUE(torch::allclose(baked.colors, colors.index_select(0, nearest), 0, 1e-5));
  // So do points without a normal (where opposite faces meet), however opaque the Gaussians.
  paint(*avatar, colors, 4.0);
  const auto no_normal = bake_gaussians_at(*avatar, mesh.vertices, torch::zeros({mesh.num_vertices(), 3}));
  EXPECT_EQ(no_normal.coverage.max().item<float>(), 0.0f);
  EXPECT_TRUE(torch::allclose(no_normal.colors, colors.index_select(0, nearest), 0, 1e-5));
}

TEST(GaussianBaking, TheMeshIsTheCharactersSubdividedWithTheRigsWeights) {
  auto avatar = avatar_of(1500);
  paint(*avatar, field(avatar->means().detach()), 4.0);
  const auto& rig = character();
  const auto baked = baked_gaussian_mesh(*avatar, rig);  // subdivisions -1: at least as many vertices as Gaussians
  EXPECT_GE(baked.mesh.num_vertices(), 1500);
  ASSERT_LT(rig.mesh.num_vertices(), 1500) << "the test expects a character with fewer vertices than Gaussians";
  // The same as subdividing the rig until it has as many vertices, carrying its weights.
  SubdividedMesh finer{rig.mesh, torch::Tensor()};
  auto weights = rig.weights.to(torch::kFloat32);
  while (finer.mesh.num_vertices() < baked.mesh.num_vertices()) {
    finer = subdivide_midpoints(finer.mesh);
    weights = carry_to_subdivision(weights, finer.parents);
  }
  EXPECT_TRUE(torch::equal(baked.mesh.vertices, finer.mesh.vertices));
  EXPECT_TRUE(torch::allclose(baked.weights, weights));
  ASSERT_EQ(baked.mesh.colors.scalar_type(), torch::kUInt8);
  const double error =
      (baked.mesh.colors.to(torch::kFloat32) / 255 - field(baked.mesh.vertices)).abs().mean().item<double>();
  EXPECT_LT(error, 0.03);
  EXPECT_NO_THROW(baked.validate("baked"));
  // Without subdivisions: the character's own vertices.
  GaussianBakingOptions own;
  own.subdivisions = 0;
  EXPECT_EQ(baked_gaussian_mesh(*avatar, rig, own).mesh.num_vertices(), rig.mesh.num_vertices());
}

TEST(GaussianBaking, LearnedWeightsAreBlendedLikeTheColours) {
  auto avatar = avatar_of(2000, false, /*learned=*/true);
  {
    // Push every Gaussian's weight onto joint 1: the blend must follow.
    torch::NoGradGuard no_grad;
    avatar->skinning_corrections().select(1, 1).fill_(20.0f);
  }
  paint(*avatar, field(avatar->means().detach()), 4.0);
  GaussianBakingOptions own;
  own.subdivisions = 0;
  const auto baked = baked_gaussian_mesh(*avatar, character(), own);
  EXPECT_TRUE(torch::allclose(baked.weights.sum(1), torch::ones({baked.mesh.num_vertices()}), 0, 1e-5));
  EXPECT_GT(baked.weights.select(1, 1).min().item<double>(), 0.99);
}

TEST(GaussianBaking, TheMeshDrawsWhatTheGaussiansDraw) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  auto avatar = avatar_of(4000);
  paint(*avatar, field(avatar->means().detach()), 4.0);
  const auto baked = baked_gaussian_mesh(*avatar, character());
  const auto split = dataset.load_split("train");
  const auto bones = split.bone_transforms[0];
  const std::array<double, 3> white{1.0, 1.0, 1.0};
  const auto camera = split.cameras[0].supersampled(4);  // 160 x 160: most covered pixels away from the outline
  const auto mesh_rgb = render_baked_mesh(baked, bones, camera, white);
  torch::NoGradGuard no_grad;
  const auto gaussians = avatar->render(bones, camera, white);
  ASSERT_EQ(mesh_rgb.sizes(), gaussians.image.sizes());
  // Where the Gaussians cover the picture, the mesh shows their colours. The
  // Gaussians here lie on the surface, not under it, and reach past the
  // mesh's outline: the pixels within 3 of the outline are left out.
  const auto outside = (gaussians.alpha <= 0.95).to(torch::kFloat32).unsqueeze(0).unsqueeze(0);
  const auto inside = torch::max_pool2d(outside, {7, 7}, {1, 1}, {3, 3})[0][0] < 0.5;
  ASSERT_GT(inside.sum().item<int64_t>(), 1000);
  const auto difference = (mesh_rgb - gaussians.image).abs().mean(2).masked_select(inside);
  EXPECT_LT(difference.mean().item<double>(), 0.03);
  EXPECT_GT((difference < 0.1).to(torch::kFloat64).mean().item<double>(), 0.99);
  EXPECT_THROW(render_baked_mesh(character(), bones, split.cameras[0], white), Error);  // no colours
}

TEST(GaussianBaking, TheFilePassesTheKhronosValidatorAndLoadsInThreeJs) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  auto avatar = avatar_of(600);
  paint(*avatar, field(avatar->means().detach()), 4.0);
  const auto dir = testing::temp_dir("gaussian_mesh_check");
  const auto glb = (dir / "mesh.glb").string(), log = (dir / "check.log").string();
  GaussianExportOptions file;
  file.bones = dataset.load_split("train").bone_transforms.narrow(0, 0, 2);
  const int64_t vertices = write_gaussian_mesh_file(glb, *avatar, character(), file);
  EXPECT_THROW(write_gaussian_mesh_file((dir / "mesh.ply").string(), *avatar, character(), file), Error);
  const std::string command = "node " + std::string(FSKIN_GLTF_CHECK) + " " + glb + " > " + log + " 2>&1";
  const int status = std::system(command.c_str());
  const std::string output = read_file(log);
  ASSERT_EQ(status, 0) << output << "\n(scripts/setup.sh installs node and the checkers)";
  EXPECT_NE(output.find("\"errors\":0,\"warnings\":0"), std::string::npos) << output;
  EXPECT_NE(output.find("\"vertices\":" + std::to_string(vertices)), std::string::npos) << output;
  EXPECT_NE(output.find("\"colors\":true,\"skinned\":true"), std::string::npos) << output;
  EXPECT_NE(output.find("\"clips\":1"), std::string::npos) << output;
}

TEST(GaussianBaking, BadOptionsAreRefused) {
  auto avatar = avatar_of(100);
  GaussianBakingOptions options;
  options.subdivisions = 5;
  EXPECT_THROW(baked_gaussian_mesh(*avatar, character(), options), Error);
  options.subdivisions = 0;
  options.neighbours = 0;
  EXPECT_THROW(baked_gaussian_mesh(*avatar, character(), options), Error);
  EXPECT_THROW(bake_gaussians_at(*avatar, torch::zeros({4, 3}), torch::zeros({3, 3})), Error);
}

}  // namespace
}  // namespace fskin
