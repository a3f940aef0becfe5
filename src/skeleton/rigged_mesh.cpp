#include "fskin/skeleton/rigged_mesh.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {

void RiggedMesh::validate(const std::string& context) const {
  mesh.validate(context);
  skeleton.validate(context);
  expect_shape(weights, {mesh.num_vertices(), skeleton.num_joints()}, context + ": weights");
  expect_finite(weights, context + ": weights");
  FSKIN_CHECK(weights.numel() == 0 || (weights.min().item<float>() >= 0 &&
                                       (weights.to(torch::kFloat64).sum(1) - 1).abs().max().item<double>() < 1e-3),
              "{}: skinning weights must be >= 0 with rows summing to 1", context);
}

torch::Tensor posed_vertices(const RiggedMesh& rigged, const torch::Tensor& bones) {
  return linear_blend_skinning(rigged.mesh.vertices.to(torch::kCPU, torch::kFloat32).unsqueeze(0),
                               rigged.weights.to(torch::kCPU, torch::kFloat32),
                               bones.to(torch::kCPU, torch::kFloat32).unsqueeze(0))[0];
}

}  // namespace fskin
