#include "fskin/inference/posed_meshing.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/geometry/mesh_topology.h"
#include "fskin/models/model_registry.h"
#include "fskin/training/occupancy_training.h"
#include "test_util.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

namespace fskin {
namespace {

using testing::SyntheticLimb;

TrainConfig small_config() { return testing::tiny_config(); }

void expect_box_near(const Box& a, const Box& b, const std::array<double, 3>& shift) {
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(a.min[axis], b.min[axis] + shift[axis], 1e-5) << "axis " << axis;
    EXPECT_NEAR(a.max[axis], b.max[axis] + shift[axis], 1e-5) << "axis " << axis;
  }
}

TEST(PosedMeshing, BoxFollowsTheBones) {
  const SyntheticLimb limb({0.0});
  auto model_ptr = make_model(small_config(), limb.skeleton());
  OccupancyModel& model = *model_ptr;
  const Box canonical = canonical_bounds(limb.skeleton(), 0.1);
  // Extent x in [-0.75, 0.75], y and z in [-0.15, 0.15]: margin 0.15.
  expect_box_near(canonical, Box{{-0.9, -0.3, -0.3}, {0.9, 0.3, 0.3}}, {0, 0, 0});
  const auto identity = torch::eye(4).expand({3, 4, 4}).contiguous();
  expect_box_near(posed_meshing_box(model, limb.skeleton(), identity, 0.1), canonical, {0, 0, 0});
  // Skinning weights sum to one, so moving every bone moves the box.
  auto moved = identity.clone();
  moved.select(2, 3).slice(1, 0, 3) += torch::tensor({0.5f, -1.0f, 2.0f});
  expect_box_near(posed_meshing_box(model, limb.skeleton(), moved, 0.1), canonical, {0.5, -1.0, 2.0});
  testing::expect_error([&] { posed_meshing_box(model, limb.skeleton(), torch::eye(4), 0.1); }, {"bones"});
}

TEST(PosedMeshing, MeshesOfATrainedLimbLieOnItsPosedSurface) {
  std::vector<double> angles;
  for (int i = 0; i < 12; ++i) angles.push_back(-1.2 + 2.4 * i / 11.0);
  const SyntheticLimb limb(angles);
  const auto run = testing::temp_dir("posed_meshing");
  TrainConfig config = small_config();
  config.steps = 200;
  config.learning_rate = 5e-3;
  config.checkpoint_every = 200;
  train(config, limb, {run.string(), false, false, nullptr});
  auto model = load_trained_model(run.string(), limb.skeleton());

  PosedMeshingOptions options;
  options.mise = MiseOptions::resolutions(12, 48);
  options.largest_component = true;
  const std::vector<double> test_angles = {0.9, -0.5};
  const auto bones = torch::stack({SyntheticLimb::bones(test_angles[0]), SyntheticLimb::bones(test_angles[1])});
  const auto poses = torch::stack({SyntheticLimb::pose(test_angles[0]), SyntheticLimb::pose(test_angles[1])});
  std::vector<Mesh> meshes;
  mesh_pose_sequence(
      *model, limb.skeleton(), bones, poses, options,
      [&](int64_t index, MeshingResult&& result) {
        EXPECT_EQ(index, static_cast<int64_t>(meshes.size()));
        EXPECT_LT(result.stats.evaluated_fraction(), 0.5);
        meshes.push_back(std::move(result.mesh));
      },
      false);
  ASSERT_EQ(meshes.size(), 2u);
  for (size_t k = 0; k < meshes.size(); ++k) {
    const auto& mesh = meshes[k];
    ASSERT_GT(mesh.num_faces(), 0);
    EXPECT_EQ(connected_components(mesh).count, 1);
    // A little outside each vertex is outside the ground-truth limb in this
    // pose and a little inside is inside: the surface sits where the pose
    // puts it (and not where the other pose would).
    const auto normals = vertex_normals(mesh);
    const auto agreement = [&](double angle) {
      const auto occupancy = [&](double offset) {
        return SyntheticLimb::occupancy(mesh.vertices + offset * normals, angle).mean().item<double>();
      };
      const double outside = 1.0 - occupancy(0.04), inside = occupancy(-0.04);
      return 0.5 * (outside + inside);
    };
    const double right = agreement(test_angles[k]), wrong = agreement(test_angles[1 - k]);
    EXPECT_GT(right, 0.85) << "angle " << test_angles[k];
    EXPECT_GT(right, wrong + 0.1) << "angle " << test_angles[k];
    std::printf("angle %.1f: agreement %.3f in its pose, %.3f in the other\n", test_angles[k], right, wrong);
  }
  // The same pose meshed alone gives the same mesh.
  const auto alone = mesh_posed(*model, limb.skeleton(), bones[0], poses[0], options);
  EXPECT_TRUE(torch::equal(alone.mesh.vertices, meshes[0].vertices));
  std::filesystem::remove_all(run);
}

}  // namespace
}  // namespace fskin
