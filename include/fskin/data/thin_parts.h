#pragma once
// Where a character is thinner than a grid can resolve: ears, fins, capes,
// tails and fingers of real assets are often thinner than the cells of the
// Fast-SNARF skinning grid, and such parts come out rounded or lose their own
// weights. `fskin train` warns with this, naming the bones the thin parts hang
// from, before it spends minutes on them.
#include <torch/types.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/data/canonical_skeleton.h"
#include "fskin/geometry/mesh.h"

namespace fskin {

struct ThinBone {
  int64_t bone = 0;
  std::string name;
  double share = 0;  // fraction of the bone's surface samples that are thin
};

struct ThinParts {
  double cell = 0;             // the length the surface was compared with
  double thin_fraction = 0;    // fraction of all surface samples that are thin
  std::vector<ThinBone> bones; // bones with a thin share >= min_share, most thin first
  // "ear.L (80 %), tail.003 (64 %)" for the first max_bones bones, then
  // "and N more"; empty when no bone is thin.
  std::string summary(size_t max_bones = 8) const;
};

struct ThinPartOptions {
  int64_t samples = 20000;   // area-uniform surface samples
  double min_share = 0.25;   // of a bone's samples, for the bone to be named
  int64_t min_samples = 20;  // a bone with fewer samples is not named
  uint64_t seed = 0;
};

// Surface samples of the closed canonical `mesh` whose thickness along the
// inward normal (the distance to where the inward ray leaves the body) is
// below `cell`, grouped by the bone of the nearest bone segment. Needs
// InsideTest (Embree); throws fskin::Error without it or for an empty mesh.
ThinParts find_thin_parts(const Mesh& mesh, const CanonicalSkeleton& skeleton, double cell,
                          const ThinPartOptions& options = {});

// Indices [K] int64 of the faces of the closed `mesh` thinner than
// `thickness` at their centroid (the same inward-ray test), for sampling them
// more densely. Needs InsideTest (Embree).
torch::Tensor thin_faces(const Mesh& mesh, double thickness);

}  // namespace fskin
