#include "fskin/export/palette.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/core/error.h"

namespace fskin {
namespace {

TEST(Palette, BoneColoursAreClearlyDistinct) {
  const auto palette = bone_palette(24).to(torch::kInt32);
  ASSERT_EQ(palette.sizes(), (std::vector<int64_t>{24, 3}));
  for (int64_t a = 0; a < 24; ++a) {
    for (int64_t b = a + 1; b < 24; ++b) {
      const int distance = (palette[a] - palette[b]).abs().sum().item<int>();
      EXPECT_GE(distance, 40) << "bones " << a << " and " << b;
    }
  }
  // The first colours do not depend on how many bones there are.
  EXPECT_TRUE(torch::equal(bone_palette(5), bone_palette(24).slice(0, 0, 5)));
}

TEST(Palette, ArgmaxColouringUsesEachVertexsDominantBone) {
  torch::manual_seed(3);
  const auto weights = torch::rand({50, 7}).softmax(1);
  const auto colors = color_by_argmax_weight(weights);
  ASSERT_EQ(colors.sizes(), (std::vector<int64_t>{50, 3}));
  ASSERT_EQ(colors.scalar_type(), torch::kUInt8);
  const auto palette = bone_palette(7);
  for (int64_t v = 0; v < 50; ++v) {
    const int64_t bone = weights[v].argmax().item<int64_t>();
    EXPECT_TRUE(torch::equal(colors[v], palette[bone])) << "vertex " << v;
  }
}

TEST(Palette, BlendedColouringMixesPaletteColours) {
  const auto palette = bone_palette(3).to(torch::kFloat32);
  const auto weights = torch::tensor({1.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.5f, 0.5f, 0.0f})
                           .reshape({3, 3});
  const auto colors = color_by_blended_weights(weights).to(torch::kFloat32);
  EXPECT_TRUE(torch::equal(colors[0], palette[0]));
  EXPECT_TRUE(torch::equal(colors[1], palette[2]));
  EXPECT_LE((colors[2] - 0.5 * (palette[0] + palette[1])).abs().max().item<float>(), 0.5f);
}

TEST(Palette, BadWeightsThrow) {
  EXPECT_THROW(bone_palette(0), Error);
  EXPECT_THROW(color_by_argmax_weight(torch::rand({5})), Error);
  EXPECT_THROW(color_by_argmax_weight(torch::ones({5, 2}, torch::kInt64)), Error);
  EXPECT_THROW(color_by_argmax_weight(torch::zeros({5, 0})), Error);
  auto nan = torch::rand({4, 2});
  nan[1][1] = std::nanf("");
  EXPECT_THROW(color_by_argmax_weight(nan), Error);
  EXPECT_THROW(color_by_blended_weights(nan), Error);
}

}  // namespace
}  // namespace fskin
