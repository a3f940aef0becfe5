#include "fskin/skeleton/lbs.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <limits>

#include "fskin/skeleton/rotations.h"

namespace fskin {
namespace {

const auto kF64 = torch::kFloat64;

torch::Tensor random_bones(int64_t batch, int64_t joints, uint64_t seed) {
  torch::manual_seed(seed);
  return make_transform(axis_angle_to_matrix(torch::randn({batch, joints, 3}, kF64)),
                        torch::randn({batch, joints, 3}, kF64));
}

TEST(Lbs, OneHotWeightsEqualRigidTransform) {
  const auto bones = random_bones(2, 4, 0);
  const auto points = torch::randn({2, 10, 3}, kF64);
  for (int64_t j = 0; j < 4; ++j) {
    const auto w = torch::nn::functional::one_hot(torch::full({10}, j, torch::kInt64), 4).to(kF64);
    const auto skinned = linear_blend_skinning(points, w, bones);
    const auto rigid = transform_points(bones.select(1, j).unsqueeze(1), points);
    EXPECT_TRUE(torch::allclose(skinned, rigid, 1e-12, 1e-12)) << "bone " << j;
  }
}

TEST(Lbs, BlendIsConvexCombinationOfRigidResults) {
  const auto bones = random_bones(1, 2, 1);
  const auto p = torch::randn({1, 5, 3}, kF64);
  const auto w = torch::tensor({0.25, 0.75}, kF64).expand({5, 2});
  const auto expected = 0.25 * transform_points(bones[0][0], p) + 0.75 * transform_points(bones[0][1], p);
  EXPECT_TRUE(torch::allclose(linear_blend_skinning(p, w, bones), expected, 1e-12, 1e-12));
}

TEST(Lbs, BatchedWeightsAndGradients) {
  const auto bones = random_bones(3, 5, 2).requires_grad_(true);
  const auto w = torch::softmax(torch::randn({3, 7, 5}, kF64), -1).requires_grad_(true);
  const auto p = torch::randn({3, 7, 3}, kF64);
  linear_blend_skinning(p, w, bones).sum().backward();
  EXPECT_TRUE(bones.grad().defined());
  EXPECT_TRUE(w.grad().abs().sum().item<double>() > 0);
}

TEST(Lbs, InvertTransformsIncludingScale) {
  auto t = random_bones(2, 3, 3);
  t.index_put_({torch::indexing::Ellipsis, torch::indexing::Slice(0, 3), torch::indexing::Slice(0, 3)},
               t.index({torch::indexing::Ellipsis, torch::indexing::Slice(0, 3),
                        torch::indexing::Slice(0, 3)}) * 2.5);
  const auto eye = torch::eye(4, kF64).expand({2, 3, 4, 4});
  EXPECT_TRUE(torch::allclose(torch::matmul(invert_transforms(t), t), eye, 1e-10, 1e-10));
}

TEST(Lbs, InvertRejectsSingularAndNonFinite) {
  auto singular = torch::eye(4, kF64).repeat({2, 1, 1});
  singular[1][2][2] = 0.0;
  EXPECT_THROW(invert_transforms(singular), std::runtime_error);
  auto nan = torch::eye(4, kF64).unsqueeze(0).clone();
  nan[0][0][3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(invert_transforms(nan), std::runtime_error);
}

TEST(Lbs, InvertOnDeviceFlagsWhatTheCheckedInverseRejects) {
  const auto good = random_bones(2, 3, 3);
  const auto on_device = invert_transforms_on_device(good);
  EXPECT_TRUE(on_device.invertible.item<bool>());
  EXPECT_EQ(on_device.invertible.dim(), 0);
  EXPECT_TRUE(torch::allclose(on_device.inverse, invert_transforms(good), 1e-12, 1e-12));
  auto singular = good.clone();
  singular[1][2].narrow(0, 0, 3).fill_(0.0);  // a zero row: det 0
  EXPECT_FALSE(invert_transforms_on_device(singular).invertible.item<bool>());
  auto infinite = good.clone();
  infinite[0][1][0][3] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(invert_transforms_on_device(infinite).invertible.item<bool>());
}

TEST(Lbs, RejectsMismatchedShapes) {
  const auto bones = random_bones(2, 4, 4);
  EXPECT_THROW(linear_blend_skinning(torch::zeros({2, 5, 3}, kF64), torch::zeros({5, 3}, kF64), bones),
               std::runtime_error);
  EXPECT_THROW(linear_blend_skinning(torch::zeros({3, 5, 3}, kF64), torch::zeros({5, 4}, kF64), bones),
               std::runtime_error);
}

}  // namespace
}  // namespace fskin
