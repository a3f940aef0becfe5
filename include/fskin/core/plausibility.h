#pragma once
// Plausible magnitudes for coordinates read from files: what passes
// expect_finite can still be corrupt (a bone scaled by 1e30 trains to NaN
// several steps later, far from the file that caused it).
#include <torch/types.h>

#include <string>

namespace fskin {

// Coordinates (metres) beyond which data read from a file is corrupt rather
// than a character: the largest a user may bring (tens of metres) is far below.
constexpr double kMaxPlausibleCoordinate = 1e6;

// Throws fskin::Error unless `tensor` is floating point, finite and every
// |value| <= kMaxPlausibleCoordinate; `name` says which input (a file and member).
void expect_plausible(const torch::Tensor& tensor, const std::string& name);

}  // namespace fskin
