#pragma once
// A triangle mesh as tensors (CPU): the one mesh type of fskin.
#include <torch/types.h>

#include <string>

namespace fskin {

struct Mesh {
  torch::Tensor vertices;  // [V, 3] float32, metres
  torch::Tensor faces;     // [F, 3] int64, counter-clockwise seen from outside
  torch::Tensor colors;    // optional [V, 3] uint8 per-vertex colours (undefined if none)

  int64_t num_vertices() const { return vertices.defined() ? vertices.size(0) : 0; }
  int64_t num_faces() const { return faces.defined() ? faces.size(0) : 0; }

  // Throws fskin::Error (prefixed with `context`) for wrong shapes/dtypes,
  // non-finite vertices or face indices out of range.
  void validate(const std::string& context) const;
};

}  // namespace fskin
