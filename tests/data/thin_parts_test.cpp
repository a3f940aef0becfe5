// Parts thinner than a grid's cell, named by the bones they hang from.
#include "fskin/data/thin_parts.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <set>

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

TEST(ThinParts, ThinFacesAreTheFacesOfTheThinParts) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  LowPolyOptions options;
  options.kind = LowPolyKind::Animal;
  const auto model = make_lowpoly_model(options);
  const auto mesh = model.template_mesh();
  const auto skeleton = testing::rest_skeleton(model);
  const auto thin = thin_faces(mesh, 0.9 / 31);
  ASSERT_GT(thin.size(0), 0);
  EXPECT_LT(thin.size(0), mesh.num_faces() / 2);
  // Their centroids hang from the ears and the tail, never from the trunk.
  const auto f = mesh.faces.index_select(0, thin);
  const auto v = mesh.vertices.to(torch::kFloat32);
  const auto centroids = (v.index_select(0, f.select(1, 0)) + v.index_select(0, f.select(1, 1)) +
                          v.index_select(0, f.select(1, 2))) / 3.0f;
  const auto bones = nearest_bone(skeleton, centroids);
  std::set<std::string> names;
  for (int64_t i = 0; i < bones.size(0); ++i) names.insert(skeleton.joint_names[bones[i].item<int64_t>()]);
  std::string all;
  for (const auto& name : names) all += name + " ";
  EXPECT_TRUE(names.count("ear.L") || names.count("ear_tip.L")) << all;
  EXPECT_TRUE(names.count("tail.002") || names.count("tail.003") || names.count("tail.004")) << all;
  for (const char* trunk : {"pelvis", "spine", "chest"}) EXPECT_EQ(names.count(trunk), 0u) << all;
  EXPECT_EQ(thin_faces(mesh, 0.002).size(0), 0);
  testing::expect_error([&] { thin_faces(mesh, -1); }, {"thickness"});
}

}  // namespace
}  // namespace fskin
