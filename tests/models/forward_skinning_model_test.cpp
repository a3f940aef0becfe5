#include "fskin/models/forward_skinning_model.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/training/train_config.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

namespace fskin {
namespace {

TEST(ForwardSkinningModel, SkinningNetworkHasItsOwnLearningRate) {
  const testing::SyntheticLimb limb({0.0});
  auto config = testing::tiny_config();
  config.skinning_learning_rate_factor = 0.25;
  ForwardSkinningModel model(model_options(config, limb.skeleton()).forward_skinning);
  const auto groups = model.parameter_groups(2e-3);
  ASSERT_EQ(groups.size(), 2u);  // occupancy, skinning
  EXPECT_DOUBLE_EQ(groups[0].learning_rate, 2e-3);
  EXPECT_DOUBLE_EQ(groups[1].learning_rate, 5e-4);
  ASSERT_NE(model.canonical_skinning_field(), nullptr);
  const auto skinning = model.canonical_skinning_field()->parameters();
  ASSERT_EQ(groups[1].parameters.size(), skinning.size());
  for (size_t k = 0; k < skinning.size(); ++k) EXPECT_TRUE(groups[1].parameters[k].is_same(skinning[k]));
  EXPECT_EQ(groups[0].parameters.size() + groups[1].parameters.size(), model.parameters().size());
}

TEST(ForwardSkinningModel, SnarfRootRuleFollowsTheConfig) {
  const testing::SyntheticLimb limb({0.0});
  auto config = testing::tiny_config();
  config.method = "snarf";
  const auto paper = model_options(config, limb.skeleton());
  EXPECT_FALSE(paper.forward_skinning.deformer.root_box.has_value());
  EXPECT_FALSE(paper.forward_skinning.deformer.remove_duplicates);
  config.snarf_roots = "in-box";
  const auto boxed = model_options(config, limb.skeleton());
  ASSERT_TRUE(boxed.forward_skinning.deformer.root_box.has_value());
  EXPECT_EQ(boxed.forward_skinning.deformer.root_box->offset, boxed.forward_skinning.box.offset);
  EXPECT_EQ(boxed.forward_skinning.deformer.root_box->scale, boxed.forward_skinning.box.scale);
  EXPECT_TRUE(boxed.forward_skinning.deformer.remove_duplicates);
  config.method = "fast-snarf";  // the rule is SNARF's; Fast-SNARF's grid already confines its roots
  EXPECT_FALSE(model_options(config, limb.skeleton()).forward_skinning.deformer.root_box.has_value());
}

TEST(ForwardSkinningModel, ImplicitGradientFollowsTheConfig) {
  const testing::SyntheticLimb limb({0.0});
  auto config = testing::tiny_config();
  for (const auto* method : {"snarf", "fast-snarf"}) {
    config.method = method;
    config.implicit_gradient = "default";
    const auto reference = model_options(config, limb.skeleton()).forward_skinning.deformer.gradient;
    EXPECT_EQ(reference, config.method == "snarf" ? GradientMode::Exact : GradientMode::Approximate) << method;
    config.implicit_gradient = "exact";
    EXPECT_EQ(model_options(config, limb.skeleton()).forward_skinning.deformer.gradient, GradientMode::Exact) << method;
    config.implicit_gradient = "approximate";
    EXPECT_EQ(model_options(config, limb.skeleton()).forward_skinning.deformer.gradient, GradientMode::Approximate) << method;
  }
}

}  // namespace
}  // namespace fskin
