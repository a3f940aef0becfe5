#include "fskin/ops/pin_pass.h"

#include <ATen/core/dispatch/Dispatcher.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <tuple>

#include "invertible/invertible_test_util.h"
#include "test_util.h"

namespace fskin {
namespace {

// (linear SIREN output, SIREN layers, map hidden layers)
using Variant = std::tuple<bool, int64_t, int64_t>;

class FusedPinPass : public ::testing::TestWithParam<Variant> {
 protected:
  Pin make_pin() const {
    const auto [linear, space_layers, map_layers] = GetParam();
    PinOptions o;
    o.num_layers = 7;  // one full cycle of the split schedule and one more 2D layer
    o.own_pose_encoder = false;
    o.coupling.embedding_dim = 10;
    o.coupling.space_hidden_dim = 24;
    o.coupling.space_layers = space_layers;
    o.coupling.space_linear_output = linear;
    o.coupling.first_omega = 10;
    o.coupling.hidden_omega = 10;  // w0 = 30 on three random sine layers amplifies float32 rounding ~100x
    o.coupling.map_hidden_dim = 12;
    o.coupling.map_hidden_layers = map_layers;
    Pin pin(o);
    testing::randomize_parameters(*pin, 0.3);
    return pin;
  }
};

TEST_P(FusedPinPass, MatchesTheModuleForwardAndInverse) {
  torch::manual_seed(21);
  auto pin = make_pin();
  torch::NoGradGuard no_grad;
  // 3 frames, 203 points: partial blocks of the 16-lane CPU kernel.
  const auto x = torch::rand({3, 203, 3}) * 2 - 1;
  const auto pose = torch::randn({3, 10});
  // The module's own float32 round trip: how much rounding this PIN amplifies.
  const double rounding =
      (pin->inverse_embedded(pin->forward_embedded(x, pose), pose) - x).abs().max().item<double>();
  const double tolerance = std::max(2e-5, 4 * rounding);
  std::cout << "[ fused PIN ] module round trip " << rounding << "\n";
  for (bool inverse : {false, true}) {
    const auto reference = inverse ? pin->inverse_embedded(x, pose) : pin->forward_embedded(x, pose);
    const auto fused = fused_pin_pass(*pin, x, pose, inverse);
    ASSERT_EQ(fused.sizes(), x.sizes());
    // Non-trivial: the PIN moves points by a sizeable fraction of the box.
    EXPECT_GT((reference - x).norm(2, -1).mean().item<double>(), 0.05);
    EXPECT_LT((fused - reference).abs().max().item<double>(), tolerance) << "inverse " << inverse;
  }
  // The fused inverse undoes the fused forward (INS eq. 14).
  const auto back = fused_pin_pass(*pin, fused_pin_pass(*pin, x, pose, false), pose, true);
  EXPECT_LT((back - x).abs().max().item<double>(), tolerance);
}

TEST_P(FusedPinPass, IsTheIdentityAtTheZeroPose) {
  torch::manual_seed(22);
  auto pin = make_pin();
  const auto x = torch::rand({1, 50, 3}) * 2 - 1;
  const auto moved = fused_pin_pass(*pin, x, torch::zeros({1, 10}), true);
  EXPECT_LT((moved - x).abs().max().item<double>(), 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Variants, FusedPinPass,
                         ::testing::Values(Variant{true, 2, 2}, Variant{false, 2, 2}, Variant{true, 3, 1},
                                           Variant{false, 1, 3}),
                         [](const ::testing::TestParamInfo<Variant>& info) {
                           return std::string(std::get<0>(info.param) ? "linear" : "sine") + "_siren" +
                                  std::to_string(std::get<1>(info.param)) + "_maps" +
                                  std::to_string(std::get<2>(info.param));
                         });

TEST(FusedPinPassInput, BadInputNamesTheProblem) {
  PinOptions o;
  o.num_layers = 2;
  o.own_pose_encoder = false;
  o.coupling.embedding_dim = 4;
  Pin pin(o);
  const auto pose = torch::zeros({1, 4});
  testing::expect_error([&] { fused_pin_pass(*pin, torch::zeros({1, 5, 2}), pose, true); }, {"fused PIN pass: points"});
  testing::expect_error([&] { fused_pin_pass(*pin, torch::zeros({1, 5, 3}), torch::zeros({1, 3}), true); },
                        {"pose embedding"});
  testing::expect_error([&] { fused_pin_pass(*pin, torch::zeros({1, 5, 3}, torch::kFloat64), pose, true); },
                        {"float32"});
  testing::expect_error(
      [&] { fused_pin_pass(*pin, torch::full({1, 5, 3}, std::numeric_limits<float>::quiet_NaN()), pose, true); },
      {"pin_pass: points", "finite"});
  o.coupling.map_hidden_dim = 300;
  Pin wide(o);
  EXPECT_FALSE(fused_pin_pass_supports(*wide));
  testing::expect_error([&] { fused_pin_pass(*wide, torch::zeros({1, 5, 3}), pose, true); }, {"too large"});
}

// The kernel is fskin::pin_pass in PyTorch's dispatcher: the packed arguments
// through the op give the C++ entry's result, and a hand-made shape list is
// checked before the kernel reads a float.
TEST(FusedPinPassInput, IsAnOperatorInPyTorchsDispatcher) {
  torch::manual_seed(23);
  PinOptions o;
  o.num_layers = 3;
  o.own_pose_encoder = false;
  o.coupling.embedding_dim = 6;
  Pin pin(o);
  const auto pose = torch::randn({2, 6}) * 0.5;
  const auto x = torch::rand({2, 40, 3}) * 2 - 1;
  const auto arguments = fused_pin_arguments(*pin, pose);
  EXPECT_EQ(arguments.packed.sizes(), (torch::IntArrayRef{2, arguments.packed.size(1)}));
  EXPECT_EQ(arguments.shape.size(), 6u + 5u * 3u);
  const auto op = c10::Dispatcher::singleton()
                      .findSchemaOrThrow("fskin::pin_pass", "")
                      .typed<torch::Tensor(const torch::Tensor&, const torch::Tensor&, c10::IntArrayRef, bool)>();
  EXPECT_TRUE(torch::equal(op.call(x, arguments.packed, arguments.shape, false), fused_pin_pass(*pin, x, pose, false)));
  auto shape = arguments.shape;
  shape[0] = 4;  // more layers than the list describes
  testing::expect_error([&] { op.call(x, arguments.packed, shape, false); }, {"pin_pass: shape", "4 layers"});
  shape = arguments.shape;
  shape[6] = 3;  // a layer moving three axes
  testing::expect_error([&] { op.call(x, arguments.packed, shape, false); }, {"pin_pass: layer 0"});
  shape = arguments.shape;
  shape[4] += 1;  // a wider map than the packed parameters hold
  testing::expect_error([&] { op.call(x, arguments.packed, shape, false); }, {"pin_pass: packed parameters"});
  testing::expect_error([&] { op.call(x, arguments.packed.narrow(0, 0, 1), arguments.shape, false); },
                        {"pin_pass: packed parameters"});
}

}  // namespace
}  // namespace fskin
