#include "fskin/geometry/mesh.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

void Mesh::validate(const std::string& context) const {
  FSKIN_CHECK(vertices.defined(), "{}: mesh has no vertices", context);
  FSKIN_CHECK(faces.defined(), "{}: mesh has no faces", context);
  expect_shape(vertices, {-1, 3}, context + ": vertices");
  expect_shape(faces, {-1, 3}, context + ": faces");
  FSKIN_CHECK(vertices.scalar_type() == torch::kFloat32,
              "{}: vertices must be float32, got {}", context,
              std::string(c10::toString(vertices.scalar_type())));
  FSKIN_CHECK(faces.scalar_type() == torch::kInt64, "{}: faces must be int64, got {}", context,
              std::string(c10::toString(faces.scalar_type())));
  expect_finite(vertices, context + ": vertices");
  if (faces.numel() > 0) {
    const int64_t lo = faces.min().item<int64_t>(), hi = faces.max().item<int64_t>();
    FSKIN_CHECK(lo >= 0 && hi < num_vertices(),
                "{}: face index out of range [0, {}): min {}, max {}", context, num_vertices(), lo,
                hi);
  }
  if (colors.defined()) {
    expect_shape(colors, {num_vertices(), 3}, context + ": colors");
  }
}

}  // namespace fskin
