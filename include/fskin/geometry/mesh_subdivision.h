#pragma once
// Midpoint subdivision: every triangle split into four at its edges'
// midpoints, the new vertices on the flat faces (no smoothing: the surface
// keeps its exact shape, as a rig's bind pose must). A subdivided mesh carries
// per-vertex data at a finer spacing (colours baked from a Gaussian avatar,
// gaussians/gaussian_baking.h); any attribute of the old vertices carries
// over by averaging each new vertex's two parents.
#include <torch/types.h>

#include "fskin/geometry/mesh.h"

namespace fskin {

struct SubdividedMesh {
  Mesh mesh;              // V + E vertices (the old ones first, in order), 4F faces, no colours
  torch::Tensor parents;  // [V + E, 2] int64: the old vertices a vertex lies halfway between ((v, v) for old ones)
};

// One level of midpoint subdivision of a validated mesh (errors name the problem).
SubdividedMesh subdivide_midpoints(const Mesh& mesh);

// values [V, C] of the old vertices -> [V + E, C] of the new mesh's, each the
// mean of its parents' (for skinning weights: rows still summing to 1).
torch::Tensor carry_to_subdivision(const torch::Tensor& values, const torch::Tensor& parents);

}  // namespace fskin
