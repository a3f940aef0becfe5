#include "fskin/losses/skinning_prior.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/fields/mlp_skinning_field.h"
#include "training/synthetic_limb.h"

namespace fskin {
namespace {

TEST(SkinningPrior, NearestSegmentBelongsToItsHeadBone) {
  const testing::SyntheticLimb limb({0.0});  // joints at x = -0.6, 0, 0.6; segments 0->1, 1->2
  const auto points = torch::tensor({{-0.5f, 0.1f, 0.0f}, {-0.05f, 0.0f, 0.2f}, {0.3f, -0.1f, 0.0f}, {2.0f, 0.0f, 0.0f}});
  const auto w = nearest_bone_weights(limb.skeleton(), points);
  ASSERT_EQ(w.sizes(), (std::vector<int64_t>{4, 3}));
  const auto bone = w.argmax(1).contiguous();
  EXPECT_EQ(std::vector<int64_t>(bone.data_ptr<int64_t>(), bone.data_ptr<int64_t>() + 4),
            (std::vector<int64_t>{0, 0, 1, 1}));
  EXPECT_TRUE(torch::allclose(w.sum(1), torch::ones({4})));
}

TEST(SkinningPrior, FittingMakesTheFieldFollowThePrior) {
  const testing::SyntheticLimb limb({0.0});
  torch::manual_seed(0);
  MlpSkinningFieldOptions options;
  options.num_bones = 3;
  options.hidden_dim = 32;
  options.hidden_layers = 2;
  MlpSkinningField field(options);
  const auto probe = torch::tensor({{-0.4f, 0.0f, 0.0f}, {0.4f, 0.05f, 0.0f}});
  const double loss = fit_skinning_prior(field, limb.skeleton(), 200, 3e-3, 1);
  EXPECT_LT(loss, 0.3);
  const auto w = field.weights(probe);
  EXPECT_GT(w[0][0].item<float>(), 0.8f);
  EXPECT_GT(w[1][1].item<float>(), 0.8f);
}

}  // namespace
}  // namespace fskin
