// Parts thinner than a grid's cell, named by the bones they hang from.
#include "fskin/data/thin_parts.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>

#include "fskin/body/body_model.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/lowpoly_character.h"
#include "data/model_skeleton.h"
#include "test_util.h"

namespace fskin {
namespace {

bool names(const ThinParts& thin, const std::string& bone) {
  return std::any_of(thin.bones.begin(), thin.bones.end(), [&](const ThinBone& b) { return b.name == bone; });
}

TEST(ThinParts, NamesTheFoxsEarsAndTailAtTheSkinningGridsCell) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  LowPolyOptions options;
  options.kind = LowPolyKind::Animal;
  const auto model = make_lowpoly_model(options);
  const auto skeleton = testing::rest_skeleton(model);
  // The default grid's cell on a 0.9 m animal: 32 voxels along its length.
  const auto coarse = find_thin_parts(model.template_mesh(), skeleton, 0.9 / 31);
  EXPECT_TRUE(names(coarse, "ear.L")) << coarse.summary();
  EXPECT_TRUE(names(coarse, "ear.R")) << coarse.summary();
  EXPECT_TRUE(names(coarse, "tail.002") || names(coarse, "tail.003")) << coarse.summary();
  EXPECT_FALSE(names(coarse, "pelvis")) << coarse.summary();  // the body is 14 cm wide
  EXPECT_GT(coarse.thin_fraction, 0.05);
  EXPECT_NE(coarse.summary().find(" %"), std::string::npos);
  // A cell finer than the thinnest part (the 8 mm ears): nothing is thin.
  const auto fine = find_thin_parts(model.template_mesh(), skeleton, 0.002);
  EXPECT_TRUE(fine.bones.empty()) << fine.summary();
  EXPECT_LT(fine.thin_fraction, 0.01);
  testing::expect_error([&] { find_thin_parts(model.template_mesh(), skeleton, 0); }, {"cell size"});
}

}  // namespace
}  // namespace fskin
