#include "fskin/benchmarking/stick2d.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "fskin/data/dataset.h"
#include "fskin/data/random.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

torch::Tensor point(double x, double y) {
  return torch::tensor({static_cast<float>(x), static_cast<float>(y)}).reshape({1, 2});
}

bool inside(const StickOptions& o, double a0, double a1, double x, double y) {
  const auto bones = stick_bone_transforms(o, torch::tensor({static_cast<float>(a0),
                                                             static_cast<float>(a1)})
                                                  .reshape({1, 2}));
  return stick_occupancy(o, bones[0], point(x, y)).item<uint8_t>() == 1;
}

TEST(Stick2d, WeightsAreNormalisedInverseDistances) {
  StickOptions o;
  const auto w = stick_skinning_weights(o, torch::tensor({0.3f, 0.05f, 1.6f, -0.08f, 1.0f, 0.1f})
                                                .reshape({3, 2}));
  // (0.3, 0.05): distance 0.05 to bone 0, hypot(0.7, 0.05) to bone 1.
  const double d0 = 0.05, d1 = std::hypot(0.7, 0.05);
  EXPECT_NEAR(w[0][0].item<float>(), (1 / d0) / (1 / d0 + 1 / d1), 1e-6);
  EXPECT_NEAR(w[1][1].item<float>(), (1 / 0.08) / (1 / 0.08 + 1 / std::hypot(0.6, 0.08)), 1e-6);
  EXPECT_NEAR(w[2][0].item<float>(), 0.5f, 1e-6);  // over the joint: equidistant
  EXPECT_TRUE(torch::allclose(w.sum(1), torch::ones({3})));
  o.with_object = true;
  const auto wo = stick_skinning_weights(o, point(1.5, 0.55));
  EXPECT_TRUE(torch::equal(wo, torch::tensor({1.0f, 0.0f}).reshape({1, 2})));  // rigid, on bone 0
}

TEST(Stick2d, RestPoseOccupancyIsTheCanonicalShape) {
  StickOptions o;
  o.with_object = true;
  Rng rng(1);
  std::vector<float> xy;
  for (int i = 0; i < 4000; ++i) xy.insert(xy.end(), {static_cast<float>(rng.uniform(-0.3, 2.3)),
                                                      static_cast<float>(rng.uniform(-0.5, 0.9))});
  const auto points = torch::tensor(xy).reshape({-1, 2});
  const auto rest = stick_bone_transforms(o, torch::zeros({1, 2}))[0];
  const auto posed = stick_occupancy(o, rest, points);
  const auto canonical = stick_canonical_occupancy(o, points);
  EXPECT_GT(canonical.sum().item<int64_t>(), 100);
  EXPECT_TRUE(torch::equal(posed, canonical));
}

TEST(Stick2d, BonesMoveTheStickAsTheAnglesSay) {
  StickOptions o;
  const double q = M_PI / 2;
  // Joint at 90 degrees: the second bone points up from (1, 0) to (1, 1).
  EXPECT_TRUE(inside(o, 0, q, 1.0, 0.9));
  EXPECT_TRUE(inside(o, 0, q, 1.0, 0.97));  // near the tip (1, 1)
  EXPECT_FALSE(inside(o, 0, q, 1.0, 1.05));
  EXPECT_FALSE(inside(o, 0, q, 1.8, 0.0));
  EXPECT_TRUE(inside(o, 0, q, 0.5, 0.0));
  // Root at -90 degrees: everything points down.
  EXPECT_TRUE(inside(o, -q, 0, 0.0, -1.7));
  EXPECT_FALSE(inside(o, -q, 0, 1.5, 0.0));
  // Near the tip the weights are (almost) all bone 1: LBS is the rigid motion.
  const auto bones = stick_bone_transforms(o, torch::tensor({0.3f, 0.7f}).reshape({1, 2}))[0];
  const auto tip = torch::tensor({1.95f, 0.0f, 0.0f}).reshape({1, 3});
  const auto w = stick_skinning_weights(o, tip);
  EXPECT_GT(w[0][1].item<float>(), 0.94f);
  const auto lbs = linear_blend_skinning(tip.unsqueeze(0), w, bones.unsqueeze(0))[0];
  const auto rigid = transform_points(bones[1], tip);
  EXPECT_LT((lbs - rigid).norm().item<float>(), 0.06f);
}

TEST(Stick2d, ObjectIsSeparateInCanonicalSpaceAndCanBeCrossedWhenPosed) {
  StickOptions o;
  o.with_object = true;
  const auto c = point(o.object_centre[0], o.object_centre[1]);
  EXPECT_EQ(stick_canonical_occupancy(o, c).item<uint8_t>(), 1);
  // Between the object and the stick: outside at rest.
  EXPECT_FALSE(inside(o, 0, 0, 1.5, 0.25));
  // Bending the joint by the object's direction puts the stick through it.
  const double towards = std::atan2(o.object_centre[1], o.object_centre[0] - o.bone_length);
  StickOptions stick_only = o;
  stick_only.with_object = false;
  EXPECT_TRUE(inside(stick_only, 0, towards, o.object_centre[0], o.object_centre[1]));
  EXPECT_TRUE(inside(o, 0, towards, o.object_centre[0], o.object_centre[1]));
  // The object rides on bone 0.
  EXPECT_TRUE(inside(o, M_PI / 2, 0, -0.55, 1.5));
  o.object_centre = {1.5, 0.2};
  testing::expect_error([&] { o.validate(); }, {"touches the stick"});
}

TEST(Stick2d, AnglesCoverTheTrainingAndExtrapolationRanges) {
  const double deg = M_PI / 180;
  const auto train = stick_angles(2000, false, 1);
  EXPECT_LE(train.abs().max().item<float>(), 60 * deg + 1e-6);
  EXPECT_GT(train.abs().max().item<float>(), 59 * deg);
  const auto extra = stick_angles(2000, true, 1);
  EXPECT_GE(extra.abs().min().item<float>(), 60 * deg - 1e-6);
  EXPECT_LE(extra.abs().max().item<float>(), 120 * deg + 1e-6);
  EXPECT_GT((extra < 0).sum().item<int64_t>(), 1500);
  EXPECT_GT((extra > 0).sum().item<int64_t>(), 1500);
}

TEST(Stick2d, FramesAreDeterministicAndLabelledByTheDefinition) {
  StickOptions o;
  o.with_object = true;
  const auto angles = stick_angles(3, true, 2);
  const auto a = make_stick_frames(o, angles, 2000, 0.01, 5);
  const auto b = make_stick_frames(o, angles, 2000, 0.01, 5);
  ASSERT_EQ(a.size(), 3u);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_TRUE(torch::equal(a[k].points, b[k].points));
    EXPECT_EQ(a[k].num_uniform, 1000);
    EXPECT_TRUE(torch::equal(a[k].points.select(1, 2), torch::zeros({2000})));
    EXPECT_TRUE(torch::equal(a[k].occupancy,
                             stick_occupancy(o, a[k].bone_transforms, a[k].points)));
    const double surface_inside = a[k].surface_occupancy().to(torch::kFloat64).mean().item<double>();
    EXPECT_NEAR(surface_inside, 0.5, 0.1);  // noise straddles the outline
    EXPECT_TRUE(torch::allclose(a[k].pose.select(1, 2), angles[k]));
  }
}

}  // namespace
}  // namespace fskin

namespace fskin {
namespace {

TEST(Stick2d, DatasetOnDiskIsReadByDatasetAndReproducible) {
  const auto a = testing::temp_dir("stick_a"), b = testing::temp_dir("stick_b");
  StickOptions stick;
  stick.with_object = true;
  StickDatasetOptions options;
  options.train = 6;
  options.val = 1;
  options.test_within = 2;
  options.test_ood = 3;
  options.points_per_frame = 400;
  options.progress = false;
  options.out_dir = a.string();
  EXPECT_EQ(build_stick_dataset(stick, options), 12);
  options.out_dir = b.string();
  build_stick_dataset(stick, options);
  for (const auto& entry : std::filesystem::directory_iterator(a))
    EXPECT_EQ(read_file(entry.path().string()),
              read_file((b / entry.path().filename()).string()))
        << entry.path();
  const auto ood = Dataset::load(a.string(), "test_ood");
  ASSERT_EQ(ood.size(), 3);
  const auto angles = ood.frame(0).pose.select(1, 2);
  EXPECT_GE(angles.abs().min().item<float>(), kStickTrainDegrees * M_PI / 180 - 1e-5);
  const auto train = Dataset::load(a.string(), "train");
  EXPECT_LE(train.frame(0).pose.abs().max().item<float>(), kStickTrainDegrees * M_PI / 180 + 1e-5);
  Rng rng(1);
  const auto batch = train.sample_batch(2, 100, 20, rng);
  EXPECT_EQ(batch.points.sizes(), (std::vector<int64_t>{2, 120, 3}));
  std::filesystem::remove_all(a);
  std::filesystem::remove_all(b);
}

}  // namespace
}  // namespace fskin
