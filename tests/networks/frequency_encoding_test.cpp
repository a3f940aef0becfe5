#include "fskin/networks/frequency_encoding.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <limits>

#include "fskin/training/train_config.h"

namespace fskin {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Columns of band k in the [x, sin, cos, sin, cos, ...] layout.
torch::Tensor band(const torch::Tensor& encoded, int64_t k) { return encoded.narrow(-1, 3 + 6 * k, 6); }

TEST(FrequencyEncoding, LayoutIsCoordinatesThenSinCosPerBand) {
  const auto x = torch::tensor({{0.25, -0.5, 0.125}}, torch::kFloat64);
  const auto encoded = positional_encoding(x, 2);
  ASSERT_EQ(encoded.size(-1), 3 + 6 * 2);
  EXPECT_TRUE(torch::equal(encoded.narrow(-1, 0, 3), x));
  EXPECT_TRUE(torch::allclose(band(encoded, 1).narrow(-1, 0, 3), (x * 2 * M_PI).sin()));
  EXPECT_TRUE(torch::allclose(band(encoded, 1).narrow(-1, 3, 3), (x * 2 * M_PI).cos()));
}

TEST(FrequencyEncoding, WindowOpensBandsCoarseToFine) {
  const auto x = torch::rand({5, 3}, torch::kFloat64) * 2 - 1;
  const auto plain = positional_encoding(x, 4);
  // A window at or past the number of bands is the plain encoding.
  EXPECT_TRUE(torch::equal(positional_encoding(x, 4, kInf), plain));
  EXPECT_TRUE(torch::equal(positional_encoding(x, 4, 4.0), plain));
  // Window 2.5: bands 0 and 1 open, band 2 at half weight (BARF eq. 14: (1 - cos(pi/2)) / 2), band 3 shut.
  const auto windowed = positional_encoding(x, 4, 2.5);
  ASSERT_EQ(windowed.sizes(), plain.sizes());
  EXPECT_TRUE(torch::equal(windowed.narrow(-1, 0, 3 + 12), plain.narrow(-1, 0, 3 + 12)));
  EXPECT_TRUE(torch::allclose(band(windowed, 2), 0.5 * band(plain, 2)));
  EXPECT_EQ(band(windowed, 3).abs().max().item<double>(), 0.0);
  EXPECT_DOUBLE_EQ(frequency_band_weight(0, 0.0), 0.0);
  EXPECT_NEAR(frequency_band_weight(1, 1.25), 0.5 * (1 - std::cos(M_PI * 0.25)), 1e-15);
}

TEST(FrequencyEncoding, TrainingWindowWidensToEveryBandBeforeTheLastStep) {
  TrainConfig config;
  config.steps = 100;
  config.encoding_frequencies = 6;
  EXPECT_EQ(frequency_window(config, 0), kInf);  // fraction 0: every band from the start
  config.encoding_window_start = 4;
  config.encoding_window_fraction = 0.5;
  EXPECT_DOUBLE_EQ(frequency_window(config, 0), 4 + 2 * (1.0 / 50));
  EXPECT_DOUBLE_EQ(frequency_window(config, 24), 5.0);
  EXPECT_LT(frequency_window(config, 48), 6.0);
  EXPECT_EQ(frequency_window(config, 49), kInf);
  EXPECT_EQ(frequency_window(config, 99), kInf);
  config.encoding_window_fraction = 1.0;
  EXPECT_EQ(frequency_window(config, 99), kInf);  // the last step trains what evaluation sees
}

}  // namespace
}  // namespace fskin
