#include "fskin/deformers/fast_snarf_deformer.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "deformers/synthetic_chain.h"
#include "fskin/core/error.h"
#include "fskin/deformers/snarf_deformer.h"
#include "fskin/fields/mlp_skinning_field.h"

namespace fskin {
namespace {

using namespace fskin::testing;

// Fraction of points whose original canonical position is among the valid candidates.
double round_trip_rate(Deformer& deformer, const torch::Tensor& canonical, const torch::Tensor& bones) {
  torch::NoGradGuard no_grad;
  const auto posed = deformer.deform(canonical, bones);
  const auto out = deformer.forward(posed, bones);
  const auto err = (out.x_canonical - canonical.unsqueeze(2)).norm(2, -1);
  const auto hit = (err < 1e-4).logical_and(out.valid).any(-1);
  return hit.to(torch::kFloat64).mean().item<double>();
}

TEST(FastSnarfDeformer, RoundTripNaturalAndExtremePoses) {
  torch::manual_seed(0);
  FastSnarfDeformer deformer(chain_field());
  const auto canonical = chain_points(4000);
  EXPECT_GE(round_trip_rate(deformer, canonical, chain_bones(0.8, 0.5)), 0.995);
  EXPECT_GE(round_trip_rate(deformer, canonical, chain_bones(-1.9, 1.6, 0.7)), 0.995);
}

TEST(FastSnarfDeformer, AutomaticAndSubsetStartsAlsoRoundTrip) {
  torch::manual_seed(1);
  const auto canonical = chain_points(2000);
  const auto bones = chain_bones(0.8, -0.6, 0.3);
  auto options = DeformerOptions::fast_snarf();
  options.start_bones = StartBones::automatic(2);
  FastSnarfDeformer automatic(chain_field(), options);
  EXPECT_GE(round_trip_rate(automatic, canonical, bones), 0.995);
  EXPECT_EQ(automatic.forward(canonical, bones).x_canonical.size(2), 2);
  options.start_bones = StartBones::subset({2, 1, 0});
  FastSnarfDeformer subset(chain_field(), options);
  EXPECT_GE(round_trip_rate(subset, canonical, bones), 0.995);
}

TEST(FastSnarfDeformer, FoldedChainGivesTwoDistinctRoots) {
  torch::manual_seed(2);
  FastSnarfDeformer deformer(chain_field());
  // The middle bone folds back over the first one: its far half overlaps it.
  const auto bones = chain_bones(2.8, 0.0);
  const auto canonical = chain_points(500, torch::kFloat32, 0.5, 0.9) * torch::tensor({1.0, 0.3, 0.3});
  torch::NoGradGuard no_grad;
  const auto out = deformer.forward(deformer.deform(canonical, bones), bones);
  const auto count = out.valid.sum(-1);
  // Spread of the valid roots of each point (max distance to the first valid one).
  const auto first = out.x_canonical.gather(2, out.valid.to(torch::kInt64).argmax(-1, true).unsqueeze(-1).expand({1, 500, 1, 3}));
  const auto spread = ((out.x_canonical - first).norm(2, -1) * out.valid).amax(-1);
  const double two_roots = ((count >= 2) & (spread > 0.5)).to(torch::kFloat64).mean().item<double>();
  EXPECT_GE(two_roots, 0.95);
  // One root lies on the middle bone (x > 0), another on the first (x < 0).
  const auto xs = out.x_canonical.select(-1, 0);
  EXPECT_TRUE(((xs > 0.3) & out.valid).any(-1).all().item<bool>());
}

TEST(FastSnarfDeformer, DuplicateRootsAreRemoved) {
  torch::manual_seed(3);
  const auto canonical = chain_points(500, torch::kFloat32, -0.9, -0.5);  // deep in bone 0
  const auto bones = chain_bones(0.3, 0.2);
  auto options = DeformerOptions::fast_snarf();
  options.remove_duplicates = false;
  FastSnarfDeformer keep(chain_field(), options);
  FastSnarfDeformer drop(chain_field());
  torch::NoGradGuard no_grad;
  const auto posed = drop.deform(canonical, bones);
  const double with = keep.forward(posed, bones).stats.mean_valid;
  const double without = drop.forward(posed, bones).stats.mean_valid;
  EXPECT_GT(with, 1.5);  // several starts reach the same root
  EXPECT_NEAR(without, 1.0, 0.02);
}

TEST(FastSnarfDeformer, ChunkingDoesNotChangeResults) {
  torch::manual_seed(4);
  const auto canonical = chain_points(300);
  const auto bones = chain_bones(0.9, 0.4);
  auto options = DeformerOptions::fast_snarf();
  FastSnarfDeformer whole(chain_field(), options);
  options.chunk_points = 7;
  FastSnarfDeformer chunked(chain_field(), options);
  torch::NoGradGuard no_grad;
  const auto posed = whole.deform(canonical, bones);
  const auto a = whole.forward(posed, bones), b = chunked.forward(posed, bones);
  EXPECT_TRUE(torch::equal(a.valid, b.valid));
  EXPECT_TRUE(torch::equal(a.x_canonical, b.x_canonical));
}

TEST(FastSnarfDeformer, SameRootsAsSnarfGivenTheSameWeights) {
  torch::manual_seed(5);
  const auto field = chain_field(torch::kFloat64);
  const auto canonical = chain_points(400, torch::kFloat64);
  const auto bones = chain_bones(1.2, -0.8, 0.2, torch::kFloat64);
  auto fast_options = DeformerOptions::fast_snarf();
  fast_options.remove_duplicates = false;
  FastSnarfDeformer fast(field, fast_options);
  SnarfDeformer snarf(field);
  torch::NoGradGuard no_grad;
  const auto posed = fast.deform(canonical, bones);
  const auto a = fast.forward(posed, bones), b = snarf.forward(posed, bones);
  const auto both = a.valid & b.valid;
  ASSERT_GT(both.sum().item<int64_t>(), 400);
  const auto diff = (a.x_canonical - b.x_canonical).norm(2, -1).masked_select(both);
  EXPECT_LT(diff.max().item<double>(), 1e-4);
}

// Inference LBS interpolates the per-voxel blended transforms (eq. 14-15);
// with gradients the weights are interpolated and blended per point. Same map.
TEST(FastSnarfDeformer, InferenceDeformEqualsPerPointBlending) {
  torch::manual_seed(6);
  FastSnarfDeformer deformer(chain_field(torch::kFloat64));
  const auto canonical = chain_points(300, torch::kFloat64).repeat({2, 1, 1}) * 1.3;  // also outside the box
  const auto bones = torch::cat({chain_bones(1.2, -0.8, 0.2, torch::kFloat64), chain_bones(-0.4, 0.9, 0.0, torch::kFloat64)});
  const auto blended = deformer.deform(canonical, bones);  // gradient mode: per-point weights
  torch::Tensor fast;
  {
    torch::NoGradGuard no_grad;
    fast = deformer.deform(canonical, bones);
  }
  EXPECT_GT((blended - canonical).norm(2, -1).mean().item<double>(), 0.1);
  EXPECT_LT((fast - blended).abs().max().item<double>(), 1e-12);
}

TEST(FastSnarfDeformer, RejectsBadInput) {
  FastSnarfDeformer deformer(chain_field());
  const auto x = chain_points(10);
  const auto bones = chain_bones(0.5, 0.5);
  auto nan_bones = bones.clone();
  nan_bones[0][1][0][0] = NAN;
  EXPECT_THROW(deformer.forward(x, nan_bones), Error);
  auto inf_bones = bones.clone();
  inf_bones[0][2][1][3] = INFINITY;
  EXPECT_THROW(deformer.forward(x, inf_bones), Error);
  auto singular = bones.clone();
  singular[0][1] = torch::zeros({4, 4});
  EXPECT_THROW(deformer.forward(x, singular), Error);
  EXPECT_THROW(deformer.forward(x, torch::zeros({1, 0, 4, 4})), Error);       // zero bones
  EXPECT_THROW(deformer.forward(x, bones.expand({2, 3, 4, 4})), Error);       // batch mismatch
  EXPECT_THROW(deformer.forward(x.narrow(2, 0, 2), bones), Error);            // [B, N, 2]
  auto nan_points = x.clone();
  nan_points[0][3][1] = NAN;
  EXPECT_THROW(deformer.forward(nan_points, bones), Error);
  EXPECT_THROW(deformer.deform(x, bones.narrow(1, 0, 2)), Error);
  auto options = DeformerOptions::fast_snarf();
  options.start_bones = StartBones::subset({0, 7});
  FastSnarfDeformer bad_starts(chain_field(), options);
  EXPECT_THROW(bad_starts.forward(x, bones), Error);
}

// --- gradients (float64) --------------------------------------------------------------

std::shared_ptr<MlpSkinningField> small_mlp_field() {
  torch::manual_seed(7);
  MlpSkinningFieldOptions o;
  o.num_bones = 3;
  o.hidden_dim = 16;
  o.hidden_layers = 2;
  auto field = std::make_shared<MlpSkinningField>(o);
  field->to(torch::kFloat64);
  return field;
}

DeformerOptions precise(DeformerOptions o, GradientMode mode) {
  o.converge_sq = 1e-26;
  o.diverge_sq = 1.0;
  o.max_iterations = 100;
  o.gradient = mode;
  o.remove_duplicates = false;
  return o;
}

// Loss = sum over valid candidates of c . x*, with fixed random c per candidate.
struct Probe {
  torch::Tensor weights;
  double operator()(Deformer& d, const torch::Tensor& posed, const torch::Tensor& bones, const torch::Tensor& mask) const {
    torch::NoGradGuard no_grad;
    const auto out = d.forward(posed, bones);
    EXPECT_TRUE(torch::equal(out.valid, mask)) << "the valid set changed under a tiny perturbation";
    return (out.x_canonical * weights).sum().item<double>();
  }
};

// Finite-difference check of d loss / d (selected parameters and x').
void check_gradients(Deformer& deformer, const torch::Tensor& canonical, const torch::Tensor& bones, double tol) {
  torch::Tensor posed;
  {
    torch::NoGradGuard no_grad;
    posed = deformer.deform(canonical, bones);
  }
  posed.requires_grad_(true);
  const auto out = deformer.forward(posed, bones);
  ASSERT_GT(out.valid.sum().item<int64_t>(), 0);
  const Probe probe{torch::randn(out.x_canonical.sizes(), torch::kFloat64)};
  (out.x_canonical * probe.weights).sum().backward();
  const double h = 1e-6;
  // x'
  const auto posed_grad = posed.grad().clone();
  for (int64_t k = 0; k < 4; ++k) {
    auto plus = posed.detach().clone(), minus = posed.detach().clone();
    plus[0][k][k % 3] += h;
    minus[0][k][k % 3] -= h;
    const double fd = (probe(deformer, plus, bones, out.valid) - probe(deformer, minus, bones, out.valid)) / (2 * h);
    EXPECT_NEAR(posed_grad[0][k][k % 3].item<double>(), fd, tol * (1 + std::abs(fd))) << "x' entry " << k;
  }
  // Field parameters: a few entries of every tensor.
  for (auto& p : deformer.field().parameters()) {
    ASSERT_TRUE(p.grad().defined());
    const auto flat = p.view({-1});
    const auto grad = p.grad().view({-1}).clone();
    for (int64_t e = 0; e < std::min<int64_t>(3, flat.numel()); ++e) {
      const int64_t i = (e * 7919) % flat.numel();
      const double orig = flat[i].item<double>();
      torch::NoGradGuard no_grad;
      flat[i] = orig + h;
      const double lp = probe(deformer, posed.detach(), bones, out.valid);
      flat[i] = orig - h;
      const double lm = probe(deformer, posed.detach(), bones, out.valid);
      flat[i] = orig;
      const double fd = (lp - lm) / (2 * h);
      EXPECT_NEAR(grad[i].item<double>(), fd, tol * (1 + std::abs(fd))) << "parameter entry " << i;
    }
  }
}

TEST(DeformerGradients, SnarfExactMatchesFiniteDifferences) {
  torch::manual_seed(8);
  SnarfDeformer deformer(small_mlp_field(), precise(DeformerOptions::snarf(), GradientMode::Exact));
  check_gradients(deformer, chain_points(12, torch::kFloat64), chain_bones(0.4, -0.3, 0.1, torch::kFloat64), 1e-5);
}

TEST(DeformerGradients, FastSnarfExactMatchesFiniteDifferencesThroughDistillation) {
  torch::manual_seed(9);
  auto box = chain_box();
  box.shape = GridShape{6, 6, 12};
  auto field = std::make_shared<DistilledSkinningField>(small_mlp_field(), box);
  FastSnarfDeformer deformer(field, precise(DeformerOptions::fast_snarf(), GradientMode::Exact));
  check_gradients(deformer, chain_points(12, torch::kFloat64), chain_bones(0.4, -0.3, 0.1, torch::kFloat64), 1e-5);
}

// Cosine similarity of the approximate (Broyden J^-1) and exact gradients.
TEST(DeformerGradients, ApproximateGradientAlignsWithExact) {
  torch::manual_seed(10);
  auto box = chain_box();
  box.shape = GridShape{8, 8, 24};
  auto field = std::make_shared<DistilledSkinningField>(small_mlp_field(), box);
  const auto canonical = chain_points(300, torch::kFloat64);
  const auto bones = chain_bones(0.9, -0.7, 0.2, torch::kFloat64);
  torch::Tensor posed;
  {
    torch::NoGradGuard no_grad;
    FastSnarfDeformer tmp(field);
    posed = tmp.deform(canonical, bones);
  }
  const auto probe = torch::randn({1, 300, 3, 3}, torch::kFloat64);
  auto gradients = [&](GradientMode mode) {
    auto o = DeformerOptions::fast_snarf();
    o.gradient = mode;
    o.remove_duplicates = false;
    FastSnarfDeformer d(field, o);
    field->zero_grad();
    const auto xp = posed.detach().clone().requires_grad_(true);
    const auto out = d.forward(xp, bones);
    (out.x_canonical * probe).sum().backward();
    std::vector<torch::Tensor> flat{xp.grad().flatten()};
    for (const auto& p : field->parameters()) flat.push_back(p.grad().flatten());
    return torch::cat(flat);
  };
  const auto exact = gradients(GradientMode::Exact);
  const auto approx = gradients(GradientMode::Approximate);
  const double cosine = (torch::dot(exact, approx) / (exact.norm() * approx.norm())).item<double>();
  EXPECT_GT(cosine, 0.99);
}

}  // namespace
}  // namespace fskin

namespace fskin {
namespace {

using namespace fskin::testing;

// The chain scaled by s (box, points, bone translations) with the options
// scaled by s takes the same Broyden steps: same roots up to s, same validity.
TEST(FastSnarfDeformer, ScaledOptionsMakeTheSearchIndependentOfUnits) {
  torch::manual_seed(3);
  const auto canonical = chain_points(3000, torch::kFloat64);
  const auto bones = chain_bones(1.2, -0.9, 0.4, torch::kFloat64);
  const auto options = DeformerOptions::fast_snarf();
  FastSnarfDeformer unit(chain_field(torch::kFloat64), options);
  torch::NoGradGuard no_grad;
  const auto posed = unit.deform(canonical, bones);
  const auto reference = unit.forward(posed, bones);
  for (double s : {0.01, 50.0}) {
    auto box = chain_box();
    for (int a = 0; a < 3; ++a) {
      box.offset[a] *= s;
      box.scale[a] /= s;
    }
    const auto field = std::make_shared<FrozenSkinningField>(chain_field(torch::kFloat64)->grid_weights(), box);
    auto scaled_bones = bones.clone();
    scaled_bones.narrow(-2, 0, 3).select(-1, 3).mul_(s);
    FastSnarfDeformer scaled(field, options.scaled(s));
    const auto out = scaled.forward(posed * s, scaled_bones);
    EXPECT_TRUE(torch::equal(out.valid, reference.valid)) << s;
    EXPECT_LT((out.x_canonical / s - reference.x_canonical).abs().max().item<double>(), 1e-9) << s;
    // Unscaled options at that size lose roots or keep wrong ones.
    FastSnarfDeformer unscaled(field, options);
    EXPECT_FALSE(torch::equal(unscaled.forward(posed * s, scaled_bones).valid, reference.valid)) << s;
  }
  EXPECT_THROW(options.scaled(0), Error);
}

}  // namespace
}  // namespace fskin
