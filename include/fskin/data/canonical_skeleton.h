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
  // The canonical mesh's faces over `extent` (then the mesh's vertices) when
  // the data has one; undefined otherwise (the 2D stick set, in-memory sources).
  torch::Tensor faces;
  // Per joint j >= 1: whether the bone segment parent(j) -> j runs inside the
  // canonical body (most of it inside the canonical mesh). Real rigs have
  // segments outside it: a root joint on the ground with the hips above it,
  // bones of IK targets or props. Empty: unknown, every segment counts.
  std::vector<bool> segment_in_body;

  // Whether the segment ending at joint j counts as a bone of the body.
  bool counts_segment(int64_t j) const {
    return segment_in_body.empty() || segment_in_body[static_cast<size_t>(j)];
  }
};

// The canonical skeleton of a dataset: its joint names and parents, the
// canonical joints of canonical.npz, and the canonical mesh's vertices as
// extent (the canonical box's corners for datasets without a mesh, such as
// the 2D stick set); segment_in_body from the canonical mesh (empty without a
// mesh or without InsideTest).
CanonicalSkeleton canonical_skeleton(const Dataset& dataset);

// CanonicalSkeleton::segment_in_body from the canonical mesh (extent and
// faces): most of nine points along the segment inside it. Empty without a
// mesh or without InsideTest (Embree).
std::vector<bool> segments_in_body(const CanonicalSkeleton& skeleton);

// Padding of the canonical box that meshing and the emptiness prior share,
// relative to its longest side.
constexpr double kCanonicalBoxPadding = 0.1;

// The bounds of the extent points and the joints, padded on every side by
// `padding` times the longest side. Throws fskin::Error on an empty or
// non-finite skeleton.
Box canonical_bounds(const CanonicalSkeleton& skeleton, double padding = kCanonicalBoxPadding);

// Per canonical point [M, 3], the bone that moves the nearest bone segment
// (parent joint p -> joint j moves with bone p) among the segments that count
// (all when none does) -> [M] int64. Throws fskin::Error for a skeleton of one joint.
torch::Tensor nearest_bone(const CanonicalSkeleton& skeleton, const torch::Tensor& points);

}  // namespace fskin
