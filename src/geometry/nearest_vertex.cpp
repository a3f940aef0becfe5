#include "fskin/geometry/nearest_vertex.h"

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <nanoflann.hpp>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {
namespace {

// nanoflann's dataset adaptor over a contiguous [V, 3] float32 array.
struct PointArray {
  const float* xyz;
  size_t count;
  size_t kdtree_get_point_count() const { return count; }
  float kdtree_get_pt(size_t i, size_t axis) const { return xyz[3 * i + axis]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointArray>, PointArray, 3,
                                                 size_t>;

}  // namespace

NearestVertices nearest_vertices(const torch::Tensor& queries, const torch::Tensor& vertices) {
  expect_shape(queries, {-1, 3}, "nearest_vertices: queries");
  expect_shape(vertices, {-1, 3}, "nearest_vertices: vertices");
  FSKIN_CHECK(vertices.size(0) > 0, "nearest_vertices: no vertices");
  expect_floating(queries, "nearest_vertices: queries");
  expect_floating(vertices, "nearest_vertices: vertices");
  const auto v = vertices.detach().to(torch::kCPU, torch::kFloat32).contiguous();
  const auto q = queries.detach().to(torch::kCPU, torch::kFloat32).contiguous();
  expect_finite(v, "nearest_vertices: vertices");
  expect_finite(q, "nearest_vertices: queries");
  const PointArray points{v.data_ptr<float>(), static_cast<size_t>(v.size(0))};
  Tree tree(3, points, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  tree.buildIndex();
  NearestVertices out{torch::empty({q.size(0)}, torch::kInt64), torch::empty({q.size(0)}, torch::kFloat32)};
  const float* query = q.data_ptr<float>();
  int64_t* index = out.index.data_ptr<int64_t>();
  float* distance = out.distance.data_ptr<float>();
  at::parallel_for(0, q.size(0), 1024, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      size_t found = 0;
      float squared = 0;
      nanoflann::KNNResultSet<float, size_t> result(1);
      result.init(&found, &squared);
      tree.findNeighbors(result, query + 3 * i, nanoflann::SearchParams());
      index[i] = static_cast<int64_t>(found);
      distance[i] = std::sqrt(squared);
    }
  });
  return out;
}

}  // namespace fskin
