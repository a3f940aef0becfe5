#pragma once
// A 3-bone chain along +x for deformer tests: bones [-1, 0], [0, 1], [1, 2],
// joints at x = 0 and x = 1, smooth weights softmax(-distance to bone / 0.1),
// stored in a voxel grid over a box that holds the chain.
#include <torch/torch.h>

#include <cmath>
#include <memory>

#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/skeleton/rotations.h"

namespace fskin::testing {

inline torch::Tensor chain_weights(const torch::Tensor& x) {
  std::vector<torch::Tensor> d;
  for (int j = 0; j < 3; ++j) {
    const auto along = x.select(-1, 0) - (j - 1.0);
    const auto t = along.clamp(0.0, 1.0);
    d.push_back(((along - t).square() + x.select(-1, 1).square() + x.select(-1, 2).square()).sqrt());
  }
  return torch::softmax(-torch::stack(d, -1) / 0.1, -1);
}

inline VoxelBox chain_box() {
  VoxelBox box;
  box.offset = {-0.5, 0.0, 0.0};
  box.scale = {1.0 / 1.7, 1.0 / 0.6, 1.0 / 0.6};
  box.shape = GridShape{16, 16, 64};
  return box;
}

inline std::shared_ptr<FrozenSkinningField> chain_field(torch::Dtype dtype = torch::kFloat32) {
  const auto box = chain_box();
  return std::make_shared<FrozenSkinningField>(chain_weights(box.voxel_centres(torch::kFloat64)).to(dtype), box);
}

// Rotation by `angle` about z around the point (px, 0, 0), [4, 4].
inline torch::Tensor rotation_about(double angle, double px, torch::Dtype dtype) {
  const auto r = axis_angle_to_matrix(torch::tensor({0.0, 0.0, angle}, torch::kFloat64));
  const auto p = torch::tensor({px, 0.0, 0.0}, torch::kFloat64);
  return make_transform(r, p - torch::matmul(r, p)).to(dtype);
}

// Bone transforms [1, 3, 4, 4]: the second bone turns by `elbow` about x = 0,
// the third by `wrist` more about x = 1, the whole chain by `root` about x = 0.
inline torch::Tensor chain_bones(double elbow, double wrist, double root = 0.0,
                                 torch::Dtype dtype = torch::kFloat32) {
  const auto b0 = rotation_about(root, 0.0, torch::kFloat64);
  const auto b1 = torch::matmul(b0, rotation_about(elbow, 0.0, torch::kFloat64));
  const auto b2 = torch::matmul(b1, rotation_about(wrist, 1.0, torch::kFloat64));
  return torch::stack({b0, b1, b2}).unsqueeze(0).to(dtype);
}

// n canonical points inside a cylinder of radius 0.25 around the chain, [1, n, 3].
inline torch::Tensor chain_points(int64_t n, torch::Dtype dtype = torch::kFloat32, double x_lo = -0.95,
                                  double x_hi = 1.95) {
  const auto x = torch::rand({n}, torch::kFloat64) * (x_hi - x_lo) + x_lo;
  const auto r = torch::rand({n}, torch::kFloat64).sqrt() * 0.25;
  const auto phi = torch::rand({n}, torch::kFloat64) * 2 * M_PI;
  return torch::stack({x, r * phi.cos(), r * phi.sin()}, -1).unsqueeze(0).to(dtype);
}

}  // namespace fskin::testing
