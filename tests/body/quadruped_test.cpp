#include "fskin/body/quadruped.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/body/smpl_skeleton.h"
#include "fskin/data/pose_generators.h"
#include "fskin/geometry/mesh_topology.h"
#include "test_util.h"

namespace fskin {
namespace {

QuadrupedOptions low_resolution(uint64_t seed = 0) {
  QuadrupedOptions o;
  o.seed = seed;
  o.resolution = 80;
  return o;
}

const BodyModel& quadruped() {
  static const BodyModel model = make_quadruped_model(low_resolution());
  return model;
}

TEST(Quadruped, IsAClosedAnimalWithThirtyThreeJoints) {
  const auto& model = quadruped();
  EXPECT_EQ(model.num_joints(), 33);
  EXPECT_FALSE(is_smpl_skeleton(model.data().joint_names));
  EXPECT_TRUE(is_builtin_quadruped(model.data().joint_names));
  const auto mesh = model.template_mesh();
  const auto topology = analyze_topology(mesh);
  EXPECT_TRUE(topology.is_closed_manifold());
  EXPECT_EQ(topology.euler_characteristic(), 2);
  EXPECT_EQ(connected_components(mesh).count, 1);
  // Standing on y = 0, facing +z, longest along z, about 1.5 m from nose to tail tip.
  const auto lo = std::get<0>(mesh.vertices.min(0)), hi = std::get<0>(mesh.vertices.max(0));
  const auto extent = hi - lo;
  EXPECT_NEAR(lo[1].item<float>(), 0.0, 0.02);
  EXPECT_NEAR(extent[2].item<float>(), 1.5, 0.05);
  EXPECT_GT(extent[2].item<float>(), 1.5 * extent[1].item<float>());
  const auto skeleton = model.skeleton();
  const auto head = skeleton.index_of("head"), tail = skeleton.index_of("tail_5");
  EXPECT_GT(skeleton.rest_joints[head][2].item<float>(), 0.2);
  EXPECT_LT(skeleton.rest_joints[tail][2].item<float>(), -0.5);
  // Left legs along +x.
  EXPECT_GT(skeleton.rest_joints[skeleton.index_of("thigh_l")][0].item<float>(), 0.05);
  EXPECT_LT(skeleton.rest_joints[skeleton.index_of("thigh_r")][0].item<float>(), -0.05);
}

TEST(Quadruped, WeightsAreSmoothAndEveryBoneDrivesSomeSkin) {
  const auto& w = quadruped().data().weights;
  EXPECT_GE(w.min().item<float>(), 0.0f);
  EXPECT_LT((w.sum(1) - 1).abs().max().item<float>(), 1e-5);
  // Every bone is the strongest influence somewhere.
  const auto best = w.argmax(1);
  for (int64_t j = 0; j < 33; ++j) EXPECT_GT((best == j).sum().item<int64_t>(), 0) << quadruped_joint_names()[j];
  // The regressed joints lie inside the body: near the designed layout.
  const auto joints = quadruped().skeleton().rest_joints;
  EXPECT_TRUE(torch::isfinite(joints).all().item<bool>());
}

TEST(Quadruped, ScalesWithLengthAndIsDeterministic) {
  auto small = low_resolution();
  small.length = 0.15;  // a mouse-sized animal meshes the same way
  const auto a = make_quadruped(small), b = make_quadruped(small);
  EXPECT_TRUE(torch::equal(a.v_template, b.v_template));
  EXPECT_TRUE(torch::equal(a.weights, b.weights));
  EXPECT_NEAR((std::get<0>(a.v_template.max(0)) - std::get<0>(a.v_template.min(0)))[2].item<float>(), 0.15, 0.005);
  // Another seed varies the proportions.
  const auto seed0 = make_quadruped(low_resolution(0)), seed3 = make_quadruped(low_resolution(3));
  EXPECT_FALSE(seed0.v_template.sizes() == seed3.v_template.sizes() && torch::equal(seed0.v_template, seed3.v_template));
  testing::expect_error([] {
    QuadrupedOptions o;
    o.resolution = 10;
    make_quadruped(o);
  }, {"--resolution"});
}

TEST(Quadruped, OodPosesBendItFurtherThanTraining) {
  const auto& model = quadruped();
  const auto& names = model.data().joint_names;
  const auto train = make_training_poses(names, {4, 10, 0});
  const auto ood = make_ood_poses(names, {8, 0});
  const auto posed_train = model.pose(train.poses);
  const auto posed_ood = model.pose(ood.poses);
  EXPECT_TRUE(torch::isfinite(posed_train.vertices).all().item<bool>());
  EXPECT_TRUE(torch::isfinite(posed_ood.vertices).all().item<bool>());
  // OOD poses move the surface further from the rest pose than training poses.
  const auto rest = model.data().v_template.unsqueeze(0);
  const double train_motion = (posed_train.vertices - rest).norm(2, -1).amax(1).mean().item<double>();
  const double ood_motion = (posed_ood.vertices - rest).norm(2, -1).amax(1).mean().item<double>();
  EXPECT_GT(ood_motion, 1.3 * train_motion) << train_motion << " vs " << ood_motion;
}

}  // namespace
}  // namespace fskin
