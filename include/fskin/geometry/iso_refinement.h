#pragma once
// Vertices of a marching-cubes mesh moved onto the level set of the field
// itself. Marching cubes places each vertex by linear interpolation of the two
// samples of its grid edge; a learned occupancy is nearly a step function
// across its surface (logits of +-10 one cell apart), so that interpolation
// puts almost every vertex at an edge's midpoint and smooth surfaces come out
// terraced, like contour lines. Here each vertex is found again on its edge
// by a few steps of regula falsi (the Illinois variant) on the field.
#include <torch/types.h>

#include <cstdint>

#include "fskin/geometry/iso_surface.h"
#include "fskin/geometry/mesh.h"

namespace fskin {

struct IsoRefinementStats {
  int64_t vertices_moved = 0;  // vertices on a grid edge with a sign change
  int64_t field_points = 0;    // field evaluations
};

// mesh: iso_surface(values, box, {iso, inside_above}) (each vertex on a grid
// edge of `box`); values [D, H, W] the samples it came from. Each vertex is
// moved along its edge to where `field` crosses `iso`, `steps` evaluations
// per vertex, `batch_size` points per field call. Faces stay as they are.
IsoRefinementStats refine_iso_vertices(Mesh& mesh, const torch::Tensor& values, const GridBox& box,
                                       const ScalarField& field, double iso, int64_t steps,
                                       int64_t batch_size = 1 << 16);

}  // namespace fskin
