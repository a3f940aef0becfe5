#include "fskin/data/canonical_skeleton.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/inside_test.h"

namespace fskin {

CanonicalSkeleton canonical_skeleton(const Dataset& dataset) {
  const auto& canonical = dataset.canonical();
  CanonicalSkeleton s;
  s.joint_names = dataset.joint_names();
  s.parents = dataset.parents();
  s.joints = canonical.joints.to(torch::kFloat32);
  s.extent = (canonical.vertices.defined() && canonical.vertices.size(0) > 0 ? canonical.vertices : canonical.box)
                 .to(torch::kFloat32);
  if (canonical.vertices.defined() && canonical.vertices.size(0) > 0 && canonical.faces.defined() &&
      canonical.faces.size(0) > 0)
    s.faces = canonical.faces;
  s.segment_in_body = segments_in_body(s);
  return s;
}

std::vector<bool> segments_in_body(const CanonicalSkeleton& s) {
  if (!s.faces.defined() || s.faces.size(0) == 0 || s.parents.size() < 2 || !inside_test_available()) return {};
  // Nine points along each segment; inside when most of them are.
  constexpr int kPoints = 9;
  const auto t = (torch::arange(kPoints, torch::kFloat32) + 1) / (kPoints + 1);
  std::vector<torch::Tensor> points;
  const auto joints = s.joints.to(torch::kFloat32);
  for (size_t j = 1; j < s.parents.size(); ++j) {
    const auto a = joints[s.parents[j]], b = joints[static_cast<int64_t>(j)];
    points.push_back(a + t.unsqueeze(1) * (b - a));
  }
  const InsideTest inside(Mesh{s.extent.to(torch::kFloat32).contiguous(), s.faces, {}});
  const auto in = inside.contains(torch::cat(points)).view({-1, kPoints}).sum(1);
  std::vector<bool> in_body(s.parents.size(), true);
  for (size_t j = 1; j < s.parents.size(); ++j) in_body[j] = in[static_cast<int64_t>(j) - 1].item<int64_t>() * 2 > kPoints;
  return in_body;
}

Box canonical_bounds(const CanonicalSkeleton& skeleton, double padding) {
  expect_shape(skeleton.extent, {-1, 3}, "canonical skeleton: extent");
  FSKIN_CHECK(skeleton.extent.size(0) > 0, "canonical skeleton: no extent points");
  expect_shape(skeleton.joints, {-1, 3}, "canonical skeleton: joints");
  return padded_bounds(torch::cat({skeleton.extent.to(torch::kFloat32), skeleton.joints.to(torch::kFloat32)}),
                       padding);
}

torch::Tensor nearest_bone(const CanonicalSkeleton& skeleton, const torch::Tensor& points) {
  expect_shape(points, {-1, 3}, "nearest bone: points");
  const int64_t J = static_cast<int64_t>(skeleton.parents.size());
  FSKIN_CHECK(J >= 2, "nearest bone: the skeleton needs >= 2 joints, has {}", J);
  bool any = false;
  for (int64_t j = 1; j < J; ++j) any = any || skeleton.counts_segment(j);
  std::vector<int64_t> heads, tails;
  for (int64_t j = 1; j < J; ++j) {
    if (any && !skeleton.counts_segment(j)) continue;
    heads.push_back(skeleton.parents[j]);
    tails.push_back(j);
  }
  const auto joints = skeleton.joints.to(points.dtype());
  const auto a = joints.index_select(0, torch::tensor(heads)), b = joints.index_select(0, torch::tensor(tails));
  const auto ab = b - a;                                               // [S, 3]
  const auto ap = points.unsqueeze(1) - a.unsqueeze(0);                // [M, S, 3]
  const auto t = ((ap * ab).sum(-1) / ab.square().sum(-1).clamp_min(1e-12)).clamp(0.0, 1.0);  // [M, S]
  const auto distance = (ap - t.unsqueeze(-1) * ab).norm(2, -1);      // [M, S]
  return torch::tensor(heads).index_select(0, distance.argmin(1));    // the segment's head joint's bone
}

}  // namespace fskin
