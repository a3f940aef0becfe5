#include "fskin/models/model_registry.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <set>

#include "test_util.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

namespace fskin {
namespace {

TEST(ModelRegistry, EveryTypeBuildsAModelThatPredicts) {
  const testing::SyntheticLimb limb({0.0});
  std::set<std::string> names;
  for (const auto& type : model_types()) {
    SCOPED_TRACE(type.name);
    EXPECT_TRUE(names.insert(type.name).second) << "a name used twice";
    EXPECT_FALSE(type.summary.empty());
    EXPECT_EQ(parse_method(type.name), type.method);
    EXPECT_EQ(method_name(type.method), type.name);
    auto config = testing::tiny_config();
    config.method = type.name;
    auto model = make_model(config, limb.skeleton());
    ASSERT_NE(model, nullptr);
    const auto bones = testing::SyntheticLimb::bones(0.3).unsqueeze(0);
    const auto pose = testing::SyntheticLimb::pose(0.3).unsqueeze(0);
    const auto logits = model->predict(torch::zeros({1, 4, 3}), bones, pose, Aggregation::Max).logits;
    EXPECT_EQ(logits.sizes(), (std::vector<int64_t>{1, 4}));
  }
  EXPECT_EQ(model_types().front().name, "fast-snarf");  // the default, listed first
  EXPECT_EQ(method_names().size(), model_types().size());
}

TEST(ModelRegistry, UnknownTypeListsTheRegisteredOnes) {
  testing::expect_error([] { model_type("nasa"); }, {"unknown method 'nasa'", "fast-snarf", "snarf", "ins", "piecewise"});
}

}  // namespace
}  // namespace fskin
