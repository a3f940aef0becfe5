#include "export/vertex_normals.h"

#include <torch/torch.h>

namespace fskin::detail {

torch::Tensor area_weighted_vertex_normals(const Mesh& mesh) {
  using torch::indexing::Slice;
  const auto& v = mesh.vertices;
  const auto& f = mesh.faces;
  const auto a = v.index_select(0, f.select(1, 0));
  const auto b = v.index_select(0, f.select(1, 1));
  const auto c = v.index_select(0, f.select(1, 2));
  // |cross| is twice the face area, so summing unnormalised cross products
  // weights each face by its area.
  const auto face_normals = torch::cross(b - a, c - a, /*dim=*/1);
  auto normals = torch::zeros_like(v);
  for (int corner = 0; corner < 3; ++corner)
    normals.index_add_(0, f.select(1, corner), face_normals);
  const auto length = normals.norm(2, /*dim=*/1, /*keepdim=*/true);
  return torch::where(length > 0, normals / length.clamp_min(1e-30), torch::zeros_like(normals));
}

}  // namespace fskin::detail
