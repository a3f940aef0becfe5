#pragma once
// The one length every default distance in fskin is relative to. The papers'
// constants (near-surface noise sigma 0.01, Broyden's residual thresholds,
// the duplicate-root distance) are lengths for SMPL bodies, about 1.7 m along
// their longest side; fskin multiplies each by
// character_size / kReferenceCharacterSize, so a 10 cm mouse and a 20 m
// dragon train like a person (docs/conventions.md, "Lengths").
#include <torch/types.h>

namespace fskin {

inline constexpr double kReferenceCharacterSize = 1.7;

// The longest side of the axis-aligned bounding box of points [N, 3]. Throws
// fskin::Error (prefixed with `what`) when points is empty, not finite, or
// spans no length.
double character_size(const torch::Tensor& points, const char* what = "character_size");

// character_size(points) / kReferenceCharacterSize.
double length_unit(const torch::Tensor& points, const char* what = "character_size");

}  // namespace fskin
