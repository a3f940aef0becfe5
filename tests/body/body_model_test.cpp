#include "fskin/body/body_model.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "fskin/skeleton/rotations.h"

namespace fskin {
namespace {

// A tetrahedron rigged to a 2-joint chain: joint 0 at the origin, joint 1 at (1,0,0).
BodyModelData tiny_model() {
  BodyModelData d;
  d.v_template = torch::tensor({0.0f, 0.0f, 0.0f, 2.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f})
                     .reshape({4, 3});
  d.faces = torch::tensor({0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}, torch::kInt64).reshape({4, 3});
  d.weights = torch::tensor({1.0f, 0.0f, 0.0f, 1.0f, 0.5f, 0.5f, 1.0f, 0.0f}).reshape({4, 2});
  // Joint 0 = vertex 0; joint 1 = midpoint of vertices 0 and 1.
  d.J_regressor = torch::tensor({1.0f, 0.0f, 0.0f, 0.0f, 0.5f, 0.5f, 0.0f, 0.0f}).reshape({2, 4});
  d.parents = {-1, 0};
  d.joint_names = {"root", "tip"};
  return d;
}

TEST(BodyModel, ZeroPoseReturnsTemplate) {
  const BodyModel model(tiny_model(), "tiny");
  const auto out = model.pose(torch::zeros({3, 2, 3}));
  EXPECT_TRUE(torch::allclose(out.vertices, model.data().v_template.expand({3, 4, 3})));
  EXPECT_TRUE(torch::allclose(out.bone_transforms, torch::eye(4).expand({3, 2, 4, 4})));
  EXPECT_TRUE(torch::allclose(out.joints[0], model.skeleton().rest_joints));
}

TEST(BodyModel, PosingMovesVerticesByTheirBones) {
  const BodyModel model(tiny_model(), "tiny");
  auto pose = torch::zeros({1, 2, 3});
  pose[0][1][2] = M_PI / 2;  // bend the tip joint by 90 degrees about z
  const auto trans = torch::tensor({{0.0f, 0.0f, 1.0f}});
  const auto out = model.pose(pose, {}, trans);
  // Vertex 1 (2,0,0) is fully on joint 1 at (1,0,0): -> (1,1,0) + trans.
  EXPECT_TRUE(torch::allclose(out.vertices[0][1], torch::tensor({1.0f, 1.0f, 1.0f}), 1e-5, 1e-6));
  // Vertex 0 is on the root and only translates.
  EXPECT_TRUE(torch::allclose(out.vertices[0][0], torch::tensor({0.0f, 0.0f, 1.0f}), 1e-5, 1e-6));
}

TEST(BodyModel, PoseCorrectivesAndShapeBlendShapesApply) {
  auto d = tiny_model();
  d.posedirs = torch::zeros({4, 3, 9});
  // Vertex 3 moves along +z by the (0,0) entry of (R_1 - I): cos(theta) - 1.
  d.posedirs[3][2][0] = 1.0f;
  d.shapedirs = torch::zeros({4, 3, 1});
  d.shapedirs[0][1][0] = 1.0f;  // vertex 0 (on the unrotated root) moves along +y
  const BodyModel model(d, "tiny");
  auto pose = torch::zeros({1, 2, 3});
  pose[0][1][2] = M_PI / 3;  // cos = 0.5 -> feature -0.5
  const auto out = model.pose(pose, torch::tensor({{0.25f}}));
  EXPECT_NEAR(out.vertices[0][3][2].item<float>(), 1.0f - 0.5f, 1e-5);
  EXPECT_NEAR(out.vertices[0][0][1].item<float>(), 0.25f, 1e-5);
}

TEST(BodyModel, PoseFeaturesAreRotationMinusIdentity) {
  const auto rot = axis_angle_to_matrix(torch::randn({2, 3, 3}));
  const auto f = pose_features(rot);
  ASSERT_EQ(f.sizes(), (std::vector<int64_t>{2, 18}));
  EXPECT_TRUE(torch::allclose(f.slice(1, 0, 9).reshape({2, 3, 3}), rot.select(1, 1) - torch::eye(3)));
}

TEST(BodyModel, RejectsBadModels) {
  {
    auto d = tiny_model();
    d.weights[2][0] = 0.9f;  // row sums to 1.4
    EXPECT_THROW(BodyModel(d, "bad"), std::runtime_error);
  }
  {
    auto d = tiny_model();
    d.faces[0][0] = 7;
    try {
      BodyModel(d, "model.npz");
      FAIL() << "expected an error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("model.npz"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
    }
  }
  {
    auto d = tiny_model();
    d.parents.clear();
    EXPECT_THROW(BodyModel(d, "bad"), std::runtime_error);
  }
  {
    auto d = tiny_model();
    d.v_template[0][0] = std::nanf("");
    EXPECT_THROW(BodyModel(d, "bad"), std::runtime_error);
  }
  {
    auto d = tiny_model();
    d.posedirs = torch::zeros({4, 3, 5});
    EXPECT_THROW(BodyModel(d, "bad"), std::runtime_error);
  }
}

TEST(BodyModel, PoseRejectsWrongJointCountAndNaN) {
  const BodyModel model(tiny_model(), "tiny");
  EXPECT_THROW(model.pose(torch::zeros({1, 3, 3})), std::runtime_error);
  auto nan_pose = torch::zeros({1, 2, 3});
  nan_pose[0][0][0] = std::nanf("");
  EXPECT_THROW(model.pose(nan_pose), std::runtime_error);
}

TEST(BodyModel, DaPoseRotatesHipsAboutForwardAxis) {
  Skeleton s{{"pelvis", "left_hip", "right_hip"}, {-1, 0, 0}, torch::zeros({3, 3})};
  const auto pose = da_pose(s, 0.5);
  EXPECT_FLOAT_EQ(pose[1][2].item<float>(), 0.5f);
  EXPECT_FLOAT_EQ(pose[2][2].item<float>(), -0.5f);
  EXPECT_FLOAT_EQ(pose.abs().sum().item<float>(), 1.0f);
  Skeleton no_hips{{"a"}, {-1}, torch::zeros({1, 3})};
  EXPECT_THROW(da_pose(no_hips), std::runtime_error);
}

}  // namespace
}  // namespace fskin
