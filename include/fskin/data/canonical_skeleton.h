#pragma once
// The skeleton in canonical space, as training, the models' bootstrap losses,
// the voxel box and meshing need it: joint names and parents, canonical joint
// positions, and points whose bounding box the canonical body fills.
#include <torch/types.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fskin/data/dataset.h"
#include "fskin/data/point_sampling.h"

namespace fskin {

struct CanonicalSkeleton {
  std::vector<std::string> joint_names;
  std::vector<int64_t> parents;  // parents[0] == -1, parents[j] < j
  torch::Tensor joints;          // [J, 3] canonical joint positions
  torch::Tensor extent;          // [M, 3] points whose bounding box the canonical body fills
};

// The canonical skeleton of a dataset: its joint names and parents, the
// canonical joints of canonical.npz, and the canonical mesh's vertices as
// extent (the canonical box's corners for datasets without a mesh, such as
// the 2D stick set).
CanonicalSkeleton canonical_skeleton(const Dataset& dataset);

// Padding of the canonical box that meshing and the emptiness prior share,
// relative to its longest side.
constexpr double kCanonicalBoxPadding = 0.1;

// The bounds of the extent points and the joints, padded on every side by
// `padding` times the longest side. Throws fskin::Error on an empty or
// non-finite skeleton.
Box canonical_bounds(const CanonicalSkeleton& skeleton, double padding = kCanonicalBoxPadding);

}  // namespace fskin
