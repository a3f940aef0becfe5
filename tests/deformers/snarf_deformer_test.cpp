#include "fskin/deformers/snarf_deformer.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "deformers/synthetic_chain.h"
#include "fskin/core/error.h"
#include "fskin/fields/mlp_skinning_field.h"

namespace fskin {
namespace {

using namespace fskin::testing;

// SNARF with an MLP field queried at every iteration: LBS forward with the
// MLP's weights, then the search recovers the canonical points.
TEST(SnarfDeformer, MlpRoundTrip) {
  torch::manual_seed(11);
  MlpSkinningFieldOptions o;
  o.num_bones = 3;
  o.hidden_dim = 32;
  o.hidden_layers = 2;
  auto field = std::make_shared<MlpSkinningField>(o);
  SnarfDeformer deformer(field);
  const auto canonical = chain_points(500);
  const auto bones = chain_bones(0.6, -0.4, 0.2);
  torch::NoGradGuard no_grad;
  const auto posed = deformer.deform(canonical, bones);
  const auto out = deformer.forward(posed, bones);
  EXPECT_EQ(out.x_canonical.sizes(), (std::vector<int64_t>{1, 500, 3, 3}));
  const auto hit = ((out.x_canonical - canonical.unsqueeze(2)).norm(2, -1) < 1e-4).logical_and(out.valid).any(-1);
  EXPECT_GE(hit.to(torch::kFloat64).mean().item<double>(), 0.995);
  EXPECT_GT(out.stats.mean_iterations, 0.0);
  // Invalid candidates are zero.
  EXPECT_TRUE((out.x_canonical.masked_select(out.valid.logical_not().unsqueeze(-1)) == 0).all().item<bool>());
}

// SNARF's "in-box" rule (Fast-SNARF's): roots outside the box are dropped,
// every other root is kept as it was.
TEST(SnarfDeformer, RootBoxDropsExactlyTheRootsOutsideIt) {
  torch::manual_seed(13);
  const auto canonical = chain_points(400);
  const auto bones = chain_bones(1.2, -0.8, 0.2);
  SnarfDeformer anywhere(chain_field());
  auto options = DeformerOptions::snarf();
  options.root_box = VoxelBox{{0.6, 0.0, 0.0}, {1 / 0.6, 0.5, 0.5}};  // x in [-1.2, 0]
  SnarfDeformer boxed(chain_field(), options);
  torch::NoGradGuard no_grad;
  const auto posed = anywhere.deform(canonical, bones);
  const auto all = anywhere.forward(posed, bones), kept = boxed.forward(posed, bones);
  const auto inside = options.root_box->contains(all.x_canonical);
  EXPECT_TRUE(torch::equal(kept.valid, all.valid & inside));
  EXPECT_GT((all.valid & inside.logical_not()).sum().item<int64_t>(), 100);  // some were dropped
  EXPECT_GT(kept.valid.sum().item<int64_t>(), 100);                          // and some kept
  EXPECT_TRUE((kept.x_canonical.select(-1, 0).masked_select(kept.valid) <= 1e-6).all().item<bool>());
}

TEST(SnarfDeformer, AutomaticStartsPickTheBoneDrivingEachPoint) {
  torch::manual_seed(12);
  auto options = DeformerOptions::snarf();
  options.start_bones = StartBones::automatic(1);
  SnarfDeformer deformer(chain_field(), options);
  // Points deep inside each bone: the single kept start is that bone's and converges at once.
  const auto canonical = torch::tensor({{{-0.7, 0.0, 0.0}, {0.5, 0.05, 0.0}, {1.6, 0.0, 0.05}}});
  const auto bones = chain_bones(0.7, 0.5);
  torch::NoGradGuard no_grad;
  const auto out = deformer.forward(deformer.deform(canonical, bones), bones);
  EXPECT_TRUE(out.valid.all().item<bool>());
  EXPECT_TRUE(torch::allclose(out.x_canonical.squeeze(2), canonical, 1e-4, 1e-4));
}

}  // namespace
}  // namespace fskin
