#include "fskin/data/canonical_skeleton.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

CanonicalSkeleton canonical_skeleton(const Dataset& dataset) {
  const auto& canonical = dataset.canonical();
  CanonicalSkeleton s;
  s.joint_names = dataset.joint_names();
  s.parents = dataset.parents();
  s.joints = canonical.joints.to(torch::kFloat32);
  s.extent = (canonical.vertices.defined() && canonical.vertices.size(0) > 0 ? canonical.vertices : canonical.box)
                 .to(torch::kFloat32);
  return s;
}

Box canonical_bounds(const CanonicalSkeleton& skeleton, double padding) {
  expect_shape(skeleton.extent, {-1, 3}, "canonical skeleton: extent");
  FSKIN_CHECK(skeleton.extent.size(0) > 0, "canonical skeleton: no extent points");
  expect_shape(skeleton.joints, {-1, 3}, "canonical skeleton: joints");
  return padded_bounds(torch::cat({skeleton.extent.to(torch::kFloat32), skeleton.joints.to(torch::kFloat32)}),
                       padding);
}

}  // namespace fskin
