#pragma once
// NeRF's frequency (positional) encoding of coordinates, the input of the
// canonical occupancy network (SNARF / Fast-SNARF with clothing: 4
// frequencies). The other encoding, the multiresolution hash grid, is an op
// of its own (ops/hash_encoding.h).
#include <torch/types.h>

#include <cstdint>

namespace fskin {

// x [..., 3] -> [x, sin(2^k pi x), cos(2^k pi x) for k < frequencies], [..., 3 + 6 F].
torch::Tensor positional_encoding(const torch::Tensor& x, int64_t frequencies);

}  // namespace fskin
