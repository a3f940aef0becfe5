// Which bone segments of a canonical skeleton run inside the body.
#include "fskin/data/canonical_skeleton.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>

#include <ATen/CPUGeneratorImpl.h>

#include "data/model_skeleton.h"
#include "fskin/losses/bootstrap_losses.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/lowpoly_character.h"
#include "test_util.h"

namespace fskin {
namespace {

BodyModel lowpoly(LowPolyKind kind) {
  LowPolyOptions options;
  options.kind = kind;
  return make_lowpoly_model(options);
}

TEST(CanonicalSkeleton, FindsTheSegmentsOutsideTheBody) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  // What canonical_skeleton(dataset) computes, on the humanoid's rest pose:
  // the segment from the weightless root on the ground up to the hips runs
  // between the legs, outside the body; the spine and the arms run inside.
  const auto model = lowpoly(LowPolyKind::Humanoid);
  auto skeleton = testing::rest_skeleton(model);
  skeleton.segment_in_body = segments_in_body(skeleton);
  const auto index = [&](const std::string& name) {
    return std::find(skeleton.joint_names.begin(), skeleton.joint_names.end(), name) - skeleton.joint_names.begin();
  };
  EXPECT_FALSE(skeleton.counts_segment(index("Hips")));  // Root -> Hips
  EXPECT_TRUE(skeleton.counts_segment(index("Spine")));
  EXPECT_TRUE(skeleton.counts_segment(index("LeftForeArm")));
  EXPECT_TRUE(skeleton.counts_segment(index("LeftUpLeg")));
  // The nearest bone of a point between the knees is a leg's or the hips', not the root's.
  const auto between_knees = torch::tensor({0.0f, 0.5f, 0.0f}).view({1, 3});
  EXPECT_NE(nearest_bone(skeleton, between_knees)[0].item<int64_t>(), 0);
  // Bootstrap points stay off the root's segment (x = z = 0 below the hips).
  auto generator = at::make_generator<at::CPUGeneratorImpl>(0);
  const auto on_root_segment = [](const torch::Tensor& p) {
    return ((p.select(1, 0).abs() < 1e-4) & (p.select(1, 2).abs() < 1e-4) & (p.select(1, 1) < 0.85)).sum().item<int64_t>();
  };
  EXPECT_EQ(on_root_segment(sample_bone_points(skeleton, 5, generator)), 0);
  skeleton.segment_in_body.clear();
  EXPECT_EQ(nearest_bone(skeleton, between_knees)[0].item<int64_t>(), 0);
  EXPECT_GT(on_root_segment(sample_bone_points(skeleton, 5, generator)), 0);
}

}  // namespace
}  // namespace fskin
