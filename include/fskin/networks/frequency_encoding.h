#pragma once
// NeRF's frequency (positional) encoding of coordinates, the input of the
// canonical occupancy network (SNARF / Fast-SNARF with clothing: 4
// frequencies). The other encoding, the multiresolution hash grid, is an op
// of its own (ops/hash_encoding.h).
#include <torch/types.h>

#include <cstdint>
#include <limits>

namespace fskin {

// x [..., 3] -> [x, sin(2^k pi x), cos(2^k pi x) for k < frequencies], [..., 3 + 6 F].
//
// `window` opens the bands coarse to fine (BARF, Lin et al. 2021, eq. 14;
// Nerfies' windowed encoding): band k is multiplied by
// (1 - cos(pi clamp(window - k, 0, 1))) / 2, so bands below floor(window) are
// fully on, band floor(window) partly, the rest off; window >= frequencies
// (the default) is the plain encoding. The output width never changes, so a
// network trained with a window reads the plain encoding afterwards.
torch::Tensor positional_encoding(const torch::Tensor& x, int64_t frequencies,
                                  double window = std::numeric_limits<double>::infinity());

// The weight of band k at `window` (the factor above).
double frequency_band_weight(int64_t band, double window);

}  // namespace fskin
