#pragma once
// Area-weighted unit vertex normals of a validated mesh, [V, 3] float32
// (zero for vertices no face uses). Shared by the renderer and the glTF writer.
#include <torch/types.h>

#include "fskin/geometry/mesh.h"

namespace fskin::detail {

torch::Tensor area_weighted_vertex_normals(const Mesh& mesh);

}  // namespace fskin::detail
