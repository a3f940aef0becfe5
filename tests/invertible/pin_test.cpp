#include "fskin/invertible/pin.h"

#include <gtest/gtest.h>

#include <iostream>
#include <limits>

#include "fskin/core/error.h"
#include "invertible/invertible_test_util.h"
#include "test_util.h"

namespace fskin {
namespace {

int64_t parameter_count(torch::nn::Module& module) {
  int64_t count = 0;
  for (const auto& p : module.parameters()) count += p.numel();
  return count;
}

double max_abs(const torch::Tensor& t) { return t.abs().max().item<double>(); }

Pin randomized_pin(torch::Dtype dtype, const PinOptions& options = {}, double scale = 0.3) {
  Pin pin(options);
  pin->to(dtype);
  testing::randomize_parameters(*pin, scale);
  return pin;
}

TEST(Pin, DefaultScheduleAndSize) {
  const auto schedule = pin_split_schedule(18);
  ASSERT_EQ(schedule.size(), 18u);
  const std::vector<std::vector<int64_t>> cycle = {{0, 1}, {2}, {1, 2}, {0}, {2, 0}, {1}};
  for (size_t k = 0; k < 18; ++k) EXPECT_EQ(schedule[k], cycle[k % 6]) << "layer " << k;

  Pin pin;
  ASSERT_EQ(pin->layers().size(), 18u);
  // Per layer (E = 120, SIREN in -> 64 -> 120, maps 240 -> 32 -> 32 -> out):
  auto siren = [](int64_t in) { return in * 64 + 64 + 64 * 120 + 120; };
  auto map = [](int64_t out) { return 120 * 32 + 32 + 120 * 32 + 32 * 32 + 32 + 32 * out; };
  const int64_t layer_2d = siren(1) + map(1) + map(2), layer_1d = siren(2) + map(1);
  const int64_t encoder = 24 * (6 * 128 + 128 + 128 * 128 + 128 + 128 * 5);
  EXPECT_EQ(parameter_count(*pin), 9 * (layer_2d + layer_1d) + encoder);
  PinOptions shared;
  shared.own_pose_encoder = false;
  Pin without_encoder(shared);
  EXPECT_EQ(parameter_count(*without_encoder), 9 * (layer_2d + layer_1d));
  std::cout << "[ PIN size ] coupling layers " << parameter_count(*without_encoder) << " parameters, with pose encoder "
            << parameter_count(*pin) << " (paper: 0.41M per PIN, 0.46M bone encoder)\n";
}

TEST(Pin, IsTheIdentityAtInitialisation) {
  torch::manual_seed(0);
  Pin pin;
  const auto x = torch::randn({2, 128, 3});
  const auto bones = testing::random_bones(2, 24, torch::kFloat32);
  EXPECT_TRUE(torch::equal(pin->forward(x, bones), x));
  EXPECT_TRUE(torch::equal(pin->inverse(x, bones), x));
}

TEST(Pin, InverseUndoesForwardForRandomPoses) {
  torch::manual_seed(1);
  for (auto dtype : {torch::kFloat64, torch::kFloat32}) {
    const double tolerance = dtype == torch::kFloat64 ? 1e-10 : 1e-5;
    // Strong perturbation: points move by up to ~20 cm, |dPIN/dx| up to ~5. The
    // round-trip error grows with the Jacobian's size (docs/ins.md).
    torch::manual_seed(1);
    auto pin = randomized_pin(dtype, {}, 0.5);
    const auto x = torch::randn({3, 256, 3}, dtype) * 0.5;
    const auto bones = testing::random_bones(3, 24, dtype);
    const auto y = pin->forward(x, bones);
    EXPECT_GT(max_abs(y - x), 0.15) << "the test needs a PIN that moves points";
    const double round_trip = max_abs(pin->inverse(y, bones) - x);
    const double other_way = max_abs(pin->forward(pin->inverse(x, bones), bones) - x);
    EXPECT_LT(round_trip, tolerance) << c10::toString(dtype);
    EXPECT_LT(other_way, tolerance) << c10::toString(dtype);
    std::cout << "[ PIN round trip ] " << c10::toString(dtype) << ": max |x - inv(fwd(x))| = " << round_trip
              << ", max |y - fwd(inv(y))| = " << other_way << ", max displacement " << max_abs(y - x) << "\n";
  }
}

TEST(Pin, IsTheIdentityAtZeroRelativePoseForAnyParameters) {
  torch::manual_seed(2);
  for (auto encoding : {RotationEncoding::kEuler, RotationEncoding::kAxisAngle, RotationEncoding::kSixD}) {
    PinOptions o;
    o.pose.rotation = encoding;
    auto pin = randomized_pin(torch::kFloat64, o);
    const auto x = torch::randn({2, 128, 3}, torch::kFloat64);
    const auto rest = testing::identity_bones(2, 24, torch::kFloat64);
    const double forward_error = max_abs(pin->forward(x, rest) - x);
    const double inverse_error = max_abs(pin->inverse(x, rest) - x);
    EXPECT_LT(forward_error, 1e-13) << to_string(encoding);
    EXPECT_LT(inverse_error, 1e-13) << to_string(encoding);
    std::cout << "[ PIN zero pose ] " << to_string(encoding) << ": max |PIN(x) - x| = " << forward_error
              << ", max |PIN^-1(x) - x| = " << inverse_error << "\n";
    EXPECT_GT(max_abs(pin->forward(x, testing::random_bones(2, 24, torch::kFloat64)) - x), 0.05);
  }
}

TEST(Pin, DifferentFramesGetDifferentDeformations) {
  torch::manual_seed(3);
  auto pin = randomized_pin(torch::kFloat64);
  const auto x = torch::randn({1, 64, 3}, torch::kFloat64).expand({2, 64, 3});
  auto bones = testing::random_bones(2, 24, torch::kFloat64);
  bones[1].copy_(testing::identity_bones(1, 24, torch::kFloat64)[0]);
  const auto y = pin->forward(x, bones);
  EXPECT_GT(max_abs(y[0] - x[0]), 0.05);
  EXPECT_LT(max_abs(y[1] - x[1]), 1e-13);  // frame 1 is at the zero relative pose
}

TEST(Pin, JacobianDeterminantIsOne) {
  torch::manual_seed(4);
  auto pin = randomized_pin(torch::kFloat64);
  const auto x = torch::randn({2, 64, 3}, torch::kFloat64) * 0.5;
  const auto bones = testing::random_bones(2, 24, torch::kFloat64);
  const auto jac = testing::point_jacobians([&](const torch::Tensor& p) { return pin->forward(p, bones); }, x);
  EXPECT_GT(max_abs(jac - torch::eye(3, torch::kFloat64)), 0.1) << "the test needs a non-trivial Jacobian";
  const double error = max_abs(torch::det(jac) - 1.0);
  EXPECT_LT(error, 1e-9);
  std::cout << "[ PIN volume ] max |det J - 1| = " << error << " over 128 points, max |J| = " << max_abs(jac)
            << "\n";
}

TEST(Pin, GradientsReachEveryParameterAndMatchFiniteDifferences) {
  torch::manual_seed(5);
  PinOptions o;
  o.num_layers = 6;  // one full cycle of splits keeps the finite differences quick
  auto pin = randomized_pin(torch::kFloat64, o);
  const auto x = torch::randn({2, 16, 3}, torch::kFloat64) * 0.5;
  const auto bones = testing::random_bones(2, 24, torch::kFloat64);
  const auto w = torch::randn({2, 16, 3}, torch::kFloat64);
  for (bool inverse : {false, true}) {
    auto loss = [&] { return ((inverse ? pin->inverse(x, bones) : pin->forward(x, bones)) * w).sum(); };
    pin->zero_grad();
    loss().backward();
    testing::expect_all_parameters_have_gradient(*pin);
    auto params = pin->named_parameters();
    for (const std::string name : {"pose_encoder.weight0", "pose_encoder.weight2", "layer0.rotation.last.weight",
                                   "layer2.space_embedding.linear1.weight", "layer5.translation.first_pose.weight"}) {
      testing::expect_gradient_matches_finite_difference(loss, params[name], {0, params[name].numel() / 3}, name);
    }
  }
}

TEST(Pin, CanBeDrivenByASharedPoseEncoder) {
  torch::manual_seed(6);
  PinOptions o;
  o.own_pose_encoder = false;
  Pin pin(o);
  testing::randomize_parameters(*pin);
  PoseEncoder encoder;
  const auto x = torch::randn({2, 64, 3});
  const auto bones = testing::random_bones(2, 24, torch::kFloat32);
  testing::expect_error([&] { pin->forward(x, bones); }, {"PIN", "no pose encoder", "forward_embedded"});
  const auto z = encoder->forward(bones);
  const auto y = pin->forward_embedded(x, z);
  EXPECT_GT(max_abs(y - x), 0.05);
  EXPECT_LT(max_abs(pin->inverse_embedded(y, z) - x), 1e-5);
}

TEST(Pin, RejectsBadInputs) {
  Pin pin;
  const auto bones = testing::identity_bones(2, 24, torch::kFloat32);
  testing::expect_error([&] { pin->forward(torch::zeros({2, 8}), bones); }, {"PIN: points", "[2, 8]"});
  testing::expect_error([&] { pin->forward(torch::zeros({3, 8, 3}), bones); }, {"PIN", "3 frames", "bones have 2"});
  testing::expect_error([&] { pin->inverse(torch::zeros({2, 8, 3}), testing::identity_bones(2, 17, torch::kFloat32)); },
                        {"PoseEncoder: bones", "[2, 17, 4, 4]"});
  auto x = torch::zeros({2, 8, 3});
  x[1][3][2] = std::numeric_limits<float>::infinity();
  testing::expect_error([&] { pin->forward(x, bones); }, {"PIN: points", "non-finite"});
  testing::expect_error([&] { pin->forward_embedded(torch::zeros({2, 8, 3}), torch::zeros({2, 100})); },
                        {"PIN: pose embedding", "[2, 120]", "[2, 100]"});
  PinOptions o;
  o.pose.per_bone_dim = 4;
  testing::expect_error([&] { Pin{o}; }, {"PinOptions", "96", "coupling.embedding_dim 120"});
}

}  // namespace
}  // namespace fskin
