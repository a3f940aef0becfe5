#include "fskin/invertible/pose_encoding.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/skeleton/rotations.h"
#include "invertible/invertible_test_util.h"
#include "test_util.h"

namespace fskin {
namespace {

using torch::indexing::Slice;

const std::vector<RotationEncoding> kEncodings = {RotationEncoding::kEuler, RotationEncoding::kAxisAngle,
                                                  RotationEncoding::kSixD};

TEST(PoseEncoding, EulerAnglesRecoverComposedRotations) {
  torch::manual_seed(0);
  const int64_t n = 200;
  const auto opts = torch::TensorOptions().dtype(torch::kFloat64);
  const auto a = (torch::rand({n}, opts) * 2 - 1) * 3.1;
  const auto b = (torch::rand({n}, opts) * 2 - 1) * 1.5;
  const auto c = (torch::rand({n}, opts) * 2 - 1) * 3.1;
  const auto zero = torch::zeros({n}, opts);
  const auto rx = axis_angle_to_matrix(torch::stack({a, zero, zero}, -1));
  const auto ry = axis_angle_to_matrix(torch::stack({zero, b, zero}, -1));
  const auto rz = axis_angle_to_matrix(torch::stack({zero, zero, c}, -1));
  const auto angles = matrix_to_euler_xyz(torch::matmul(rz, torch::matmul(ry, rx)));
  EXPECT_TRUE(torch::allclose(angles, torch::stack({a, b, c}, -1), 1e-9, 1e-9));
}

TEST(PoseEncoding, IdentityTransformHasZeroFeatures) {
  for (auto encoding : kEncodings) {
    const auto features = bone_features(testing::identity_bones(2, 3, torch::kFloat32), encoding);
    EXPECT_EQ(features.sizes(), (std::vector<int64_t>{2, 3, 3 + rotation_encoding_dim(encoding)}));
    EXPECT_TRUE(torch::equal(features, torch::zeros_like(features))) << to_string(encoding);
  }
}

TEST(PoseEncoding, FeaturesAreTranslationThenRotation) {
  torch::manual_seed(1);
  const auto bones = testing::random_bones(2, 4, torch::kFloat64);
  const auto rotation = bones.index({Slice(), Slice(), Slice(0, 3), Slice(0, 3)});
  const auto translation = bones.index({Slice(), Slice(), Slice(0, 3), 3});
  const auto six_d = bone_features(bones, RotationEncoding::kSixD);
  EXPECT_TRUE(torch::allclose(six_d.index({Slice(), Slice(), Slice(0, 3)}), translation));
  // 6D: columns c0, c1 minus the identity's (1, 0, 0), (0, 1, 0).
  const auto c0 = six_d.index({Slice(), Slice(), Slice(3, 6)}) + torch::tensor({1.0, 0.0, 0.0}, torch::kFloat64);
  const auto c1 = six_d.index({Slice(), Slice(), Slice(6, 9)}) + torch::tensor({0.0, 1.0, 0.0}, torch::kFloat64);
  EXPECT_TRUE(torch::allclose(c0, rotation.index({Slice(), Slice(), Slice(), 0})));
  EXPECT_TRUE(torch::allclose(c1, rotation.index({Slice(), Slice(), Slice(), 1})));
  const auto axis_angle = bone_features(bones, RotationEncoding::kAxisAngle);
  EXPECT_TRUE(torch::allclose(axis_angle.index({Slice(), Slice(), Slice(3, 6)}), matrix_to_axis_angle(rotation)));
}

TEST(PoseEncoding, ParsesEncodingNames) {
  for (auto encoding : kEncodings) EXPECT_EQ(parse_rotation_encoding(to_string(encoding)), encoding);
  testing::expect_error([] { parse_rotation_encoding("quaternion"); }, {"quaternion", "euler", "6d"});
}

TEST(PoseEncoding, DefaultEncoderMatchesThePaperSizes) {
  PoseEncoder encoder;
  EXPECT_EQ(encoder->options().embedding_dim(), 120);
  int64_t count = 0;
  for (const auto& p : encoder->parameters()) count += p.numel();
  // Per bone 6 -> 128 -> 128 -> 5 (no last bias): 24 x 18,048 = 0.43M (paper: 0.46M).
  EXPECT_EQ(count, 24 * (6 * 128 + 128 + 128 * 128 + 128 + 128 * 5));
}

TEST(PoseEncoding, ZeroRelativePoseGivesZeroEmbedding) {
  torch::manual_seed(2);
  for (auto encoding : kEncodings) {
    PoseEncoderOptions o;
    o.rotation = encoding;
    PoseEncoder encoder(o);
    encoder->to(torch::kFloat64);
    testing::randomize_parameters(*encoder);
    const auto zero = encoder->forward(testing::identity_bones(3, 24, torch::kFloat64));
    EXPECT_EQ(zero.sizes(), (std::vector<int64_t>{3, 120}));
    EXPECT_LT(zero.abs().max().item<double>(), 1e-14) << to_string(encoding);
    const auto posed = encoder->forward(testing::random_bones(3, 24, torch::kFloat64));
    EXPECT_GT(posed.abs().min().item<double>(), 0.0) << to_string(encoding);
  }
}

TEST(PoseEncoding, EachBoneHasItsOwnColumns) {
  torch::manual_seed(3);
  PoseEncoderOptions o;
  o.num_bones = 6;
  o.per_bone_dim = 4;
  o.rotation = RotationEncoding::kSixD;
  PoseEncoder encoder(o);
  auto bones = testing::random_bones(2, 6, torch::kFloat32);
  const auto before = encoder->forward(bones);
  bones.index_put_({Slice(), 3}, testing::random_bones(2, 1, torch::kFloat32).squeeze(1));
  const auto changed = (encoder->forward(bones) - before).abs().amax(0) > 0;  // [24]
  for (int64_t column = 0; column < 24; ++column) {
    EXPECT_EQ(changed[column].item<bool>(), column / 4 == 3) << "column " << column;
  }
  // Identical transforms on different bones give different outputs: separate weights.
  const auto same = testing::random_bones(1, 1, torch::kFloat32).expand({1, 6, 4, 4}).contiguous();
  const auto out = encoder->forward(same).reshape({6, 4});
  EXPECT_FALSE(torch::allclose(out[0], out[1]));
}

TEST(PoseEncoding, GradientsMatchFiniteDifferences) {
  torch::manual_seed(4);
  PoseEncoderOptions o;
  o.num_bones = 3;
  o.hidden_dim = 16;
  PoseEncoder encoder(o);
  encoder->to(torch::kFloat64);
  const auto bones = testing::random_bones(2, 3, torch::kFloat64);
  const auto w = torch::randn({2, 15}, torch::kFloat64);
  auto loss = [&] { return (encoder->forward(bones) * w).sum(); };
  loss().backward();
  testing::expect_all_parameters_have_gradient(*encoder);
  for (const auto& p : encoder->named_parameters()) {
    testing::expect_gradient_matches_finite_difference(loss, p.value(), {0, 7, p.value().numel() - 1}, p.key());
  }
}

// A chain with a branch: 0 -> 1 -> {2, 3}.
const std::vector<int64_t> kParents = {-1, 0, 1, 1};

PosedSkeleton posed_chain(const torch::Tensor& local_rotations) {
  const auto rest = torch::tensor({0.0, 0.0, 0.0, 0.0, 0.4, 0.0, 0.2, 0.7, 0.1, -0.3, 0.6, 0.0},
                                  torch::kFloat64).reshape({4, 3});
  return forward_kinematics(kParents, rest, local_rotations, torch::tensor({{0.1, -0.2, 0.3}}, torch::kFloat64));
}

TEST(PoseEncoding, ParentFrameSeesEachJointsOwnRotation) {
  torch::manual_seed(5);
  const auto local = axis_angle_to_matrix(torch::randn({1, 4, 3}, torch::kFloat64));
  const auto bones = posed_chain(local).bone_transforms;
  const auto relative = parent_relative_transforms(bones, kParents);
  EXPECT_TRUE(torch::equal(relative[0][0], bones[0][0]));  // the root keeps its transform
  for (int64_t j = 1; j < 4; ++j) {
    EXPECT_TRUE(torch::allclose(relative[0][j].index({Slice(0, 3), Slice(0, 3)}), local[0][j], 1e-12, 1e-12))
        << "joint " << j;
    EXPECT_TRUE(torch::allclose(relative[0][j][3], torch::tensor({0.0, 0.0, 0.0, 1.0}, torch::kFloat64)));
  }
  const auto identity = testing::identity_bones(2, 4, torch::kFloat64);
  EXPECT_TRUE(torch::equal(parent_relative_transforms(identity, kParents), identity));
}

TEST(PoseEncoding, ParentFrameKeepsAnAncestorsMotionOutOfItsChildren) {
  torch::manual_seed(6);
  const auto opts = torch::TensorOptions().dtype(torch::kFloat64);
  auto axis_angles = torch::randn({1, 4, 3}, opts);
  const auto before = posed_chain(axis_angle_to_matrix(axis_angles)).bone_transforms;
  axis_angles.index_put_({0, 1}, torch::randn({3}, opts));  // bend joint 1 only
  const auto after = posed_chain(axis_angle_to_matrix(axis_angles)).bone_transforms;
  for (auto frame : {PoseFrame::kGlobal, PoseFrame::kParent}) {
    PoseEncoderOptions o;
    o.num_bones = 4;
    o.per_bone_dim = 2;
    o.hidden_dim = 8;
    o.frame = frame;
    o.parents = kParents;
    PoseEncoder encoder(o);
    encoder->to(torch::kFloat64);
    const auto changed = (encoder->forward(after) - encoder->forward(before)).abs().reshape({4, 2}).amax(1) > 1e-12;
    // Global: joint 1 moves the transforms of 1 and its children 2, 3; parent: joint 1's own only.
    const std::vector<bool> expected = frame == PoseFrame::kGlobal ? std::vector<bool>{false, true, true, true}
                                                                   : std::vector<bool>{false, true, false, false};
    for (int64_t j = 0; j < 4; ++j) EXPECT_EQ(changed[j].item<bool>(), expected[j]) << to_string(frame) << " bone " << j;
  }
  EXPECT_EQ(parse_pose_frame("parent"), PoseFrame::kParent);
  testing::expect_error([] { parse_pose_frame("local"); }, {"local", "global", "parent"});
  PoseEncoderOptions missing;
  missing.frame = PoseFrame::kParent;
  testing::expect_error([&] { PoseEncoder{missing}; }, {"PoseEncoderOptions", "parents"});
}

TEST(PoseEncoding, BoneDropoutZeroesWholeBonesInTrainingOnly) {
  torch::manual_seed(7);
  PoseEncoderOptions o;
  o.num_bones = 8;
  o.per_bone_dim = 3;
  o.hidden_dim = 8;
  o.bone_dropout = 0.5;
  PoseEncoder encoder(o);
  encoder->to(torch::kFloat64);
  const auto bones = testing::random_bones(64, 8, torch::kFloat64);
  encoder->eval();
  const auto full = encoder->forward(bones).reshape({64, 8, 3});
  encoder->train();
  const auto dropped = encoder->forward(bones).reshape({64, 8, 3});
  // Each (frame, bone) slice is either all zero or the evaluation slice x 2.
  const auto zero = dropped.abs().amax(-1) == 0;
  const auto scaled = (dropped - 2 * full).abs().amax(-1) < 1e-12;
  EXPECT_TRUE((zero ^ scaled).all().item<bool>());
  const double dropped_fraction = zero.to(torch::kFloat64).mean().item<double>();
  EXPECT_GT(dropped_fraction, 0.4);  // 512 draws of p = 0.5
  EXPECT_LT(dropped_fraction, 0.6);
  o.bone_dropout = 1.0;
  testing::expect_error([&] { PoseEncoder{o}; }, {"PoseEncoderOptions", "bone_dropout"});
}

TEST(PoseEncoding, RejectsBadBones) {
  PoseEncoder encoder;
  testing::expect_error([&] { encoder->forward(testing::identity_bones(2, 23, torch::kFloat32)); },
                        {"PoseEncoder: bones", "[*, 24, 4, 4]", "[2, 23, 4, 4]"});
  auto bones = testing::identity_bones(2, 24, torch::kFloat32);
  bones[1][5][0][3] = std::nan("");
  testing::expect_error([&] { encoder->forward(bones); }, {"PoseEncoder: bones", "non-finite"});
  testing::expect_error([&] { encoder->forward(testing::identity_bones(2, 24, torch::kFloat64)); },
                        {"PoseEncoder", "Double", "Float"});
  PoseEncoderOptions o;
  o.per_bone_dim = 0;
  testing::expect_error([&] { PoseEncoder{o}; }, {"PoseEncoderOptions", "per_bone_dim"});
}

}  // namespace
}  // namespace fskin
