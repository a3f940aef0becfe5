#pragma once
// Nearest vertex of a point cloud for many query points: a k-d tree over the
// vertices (nanoflann, Debian's libnanoflann-dev), queries in parallel. It
// replaces brute-force distance matrices (a 64 x 64 x 16 voxel grid against a
// 10k-vertex body is 650M distances) in the preset skinning grids.
#include <torch/types.h>

namespace fskin {

struct NearestVertices {
  torch::Tensor index;     // [Q] int64, into the vertices
  torch::Tensor distance;  // [Q] float32, Euclidean
};

// queries [Q, 3], vertices [V, 3] (V >= 1), any floating dtype, CPU or not
// (computed on the host, in float32); of equally near vertices, any one.
NearestVertices nearest_vertices(const torch::Tensor& queries, const torch::Tensor& vertices);

}  // namespace fskin
