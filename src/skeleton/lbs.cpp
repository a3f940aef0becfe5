#include "fskin/skeleton/lbs.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

using torch::indexing::Ellipsis;
using torch::indexing::Slice;

torch::Tensor blend_transforms(const torch::Tensor& weights, const torch::Tensor& bones) {
  expect_shape(bones, {-1, -1, 4, 4}, "blend_transforms: bones");
  const int64_t B = bones.size(0), J = bones.size(1);
  auto w = weights;
  if (w.dim() == 2) w = w.unsqueeze(0).expand({B, w.size(0), w.size(1)});
  expect_shape(w, {B, -1, J}, "blend_transforms: weights");
  const auto flat = torch::matmul(w.to(bones.dtype()), bones.reshape({B, J, 16}));  // [B, N, 16]
  return flat.reshape({B, w.size(1), 4, 4});
}

torch::Tensor transform_points(const torch::Tensor& transforms, const torch::Tensor& points) {
  FSKIN_CHECK(points.dim() >= 1 && points.size(-1) == 3,
              "transform_points: points must be [..., 3], got {}", shape_string(points.sizes()));
  const auto rot = transforms.index({Ellipsis, Slice(0, 3), Slice(0, 3)});
  const auto t = transforms.index({Ellipsis, Slice(0, 3), 3});
  return torch::matmul(rot, points.unsqueeze(-1)).squeeze(-1) + t;
}

torch::Tensor linear_blend_skinning(const torch::Tensor& points, const torch::Tensor& weights,
                                    const torch::Tensor& bones) {
  expect_shape(points, {bones.size(0), -1, 3}, "linear_blend_skinning: points");
  return transform_points(blend_transforms(weights, bones), points);
}

torch::Tensor invert_transforms(const torch::Tensor& transforms) {
  // The same inverse as on a device, with its check read at once; the details
  // (which values, how many matrices) only when it fails.
  auto result = invert_transforms_on_device(transforms);
  if (!result.invertible.item<bool>()) {
    expect_finite(transforms, "invert_transforms: transforms");
    const auto det = torch::det(transforms.index({Ellipsis, Slice(0, 3), Slice(0, 3)}));
    fail("invert_transforms: singular transform (|det| <= 1e-8 for {} of {} matrices)",
         (det.abs() <= 1e-8).sum().item<int64_t>(), det.numel());
  }
  return result.inverse;
}

TransformInverse invert_transforms_on_device(const torch::Tensor& transforms) {
  FSKIN_CHECK(transforms.dim() >= 2 && transforms.size(-1) == 4 && transforms.size(-2) == 4,
              "invert_transforms: expected [..., 4, 4], got {}", shape_string(transforms.sizes()));
  const auto rot = transforms.index({Ellipsis, Slice(0, 3), Slice(0, 3)});
  // The 3x3 blocks' inverses in closed form, the adjugate over the
  // determinant (columns r1 x r2, r2 x r0, r0 x r1 of rows r0, r1, r2): no
  // error flags to read back, and on the CPU LAPACK's batched LU took
  // milliseconds for a skeleton's few blocks, 5 % of a Gaussian avatar's
  // pose-fitting step (torch.profiler, 2 threads).
  const auto r0 = rot.select(-2, 0), r1 = rot.select(-2, 1), r2 = rot.select(-2, 2);
  const auto c0 = torch::cross(r1, r2, -1), c1 = torch::cross(r2, r0, -1), c2 = torch::cross(r0, r1, -1);
  const auto det = (r0 * c0).sum(-1);
  const auto inv_rot = torch::stack({c0, c1, c2}, -1) / det.unsqueeze(-1).unsqueeze(-1);
  const auto t = transforms.index({Ellipsis, Slice(0, 3), 3});
  const auto invertible = torch::isfinite(transforms).all() & (det.abs() > 1e-8).all();
  return {make_transform(inv_rot, -torch::matmul(inv_rot, t.unsqueeze(-1)).squeeze(-1)), invertible};
}

torch::Tensor make_transform(const torch::Tensor& rotation, const torch::Tensor& translation) {
  auto top = torch::cat({rotation, translation.unsqueeze(-1)}, -1);  // [.., 3, 4]
  auto bottom = torch::zeros_like(top.narrow(-2, 0, 1));
  bottom.select(-1, 3).fill_(1.0);
  return torch::cat({top, bottom}, -2);
}

}  // namespace fskin
