#include "fskin/training/dataset_source.h"

#include <torch/torch.h>

#include <algorithm>

#include "fskin/body/character.h"
#include "fskin/core/error.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {

namespace {

// Least-squares fixed point of rotations about r: sum_k |(I - R_k) r - t_k|^2
// + weight |r - prior|^2, with R [K, 3, 3], t [K, 3] (float64).
torch::Tensor rotation_centre(const torch::Tensor& R, const torch::Tensor& t, const torch::Tensor& prior,
                              double weight) {
  const auto A = torch::eye(3, R.options()) - R;                       // [K, 3, 3]
  const auto At = A.transpose(1, 2);
  const auto normal = torch::matmul(At, A).sum(0) + weight * torch::eye(3, R.options());
  const auto rhs = torch::matmul(At, t.unsqueeze(-1)).squeeze(-1).sum(0) + weight * prior;
  return torch::linalg_solve(normal, rhs.unsqueeze(-1)).squeeze(-1);
}

}  // namespace

CanonicalSkeleton canonical_skeleton(const Dataset& dataset) {
  CanonicalSkeleton s;
  s.joint_names = dataset.joint_names();
  FSKIN_CHECK(s.joint_names == smpl_joint_names(),
              "dataset skeleton: training needs SMPL's 24 joints in SMPL order (got {} joints starting '{}')",
              s.joint_names.size(), s.joint_names.empty() ? std::string() : s.joint_names.front());
  s.parents = smpl_parents();
  FSKIN_CHECK(dataset.size() > 0, "dataset skeleton: the '{}' split has no frames", dataset.split());
  const auto& canonical = dataset.canonical();
  FSKIN_CHECK(canonical.vertices.defined() && canonical.vertices.size(0) > 0,
              "dataset skeleton: the canonical frame has no mesh");
  s.extent = canonical.vertices.to(torch::kFloat32);

  const int64_t K = dataset.size(), J = static_cast<int64_t>(s.parents.size());
  std::vector<torch::Tensor> rest, trans;
  for (int64_t k = 0; k < K; ++k) {
    rest.push_back(dataset.frame(k).bone_transforms_rest.to(torch::kFloat64));
    trans.push_back(dataset.frame(k).trans.to(torch::kFloat64));
  }
  const auto G = torch::stack(rest), T = torch::stack(trans);  // [K, J, 4, 4], [K, 3]
  // A weak pull (one frame's worth in K) only decides directions no frame rotates about.
  const double weight = 1e-3 * static_cast<double>(K);
  std::vector<torch::Tensor> joints(J);
  const auto centroid = canonical.vertices.to(torch::kFloat64).mean(0);
  const auto G0 = G.select(1, 0);
  joints[0] = rotation_centre(G0.slice(1, 0, 3).slice(2, 0, 3), G0.slice(1, 0, 3).select(2, 3) - T, centroid, weight);
  for (int64_t j = 1; j < J; ++j) {
    const auto relative = torch::matmul(invert_transforms(G.select(1, s.parents[j])), G.select(1, j));
    joints[j] = rotation_centre(relative.slice(1, 0, 3).slice(2, 0, 3), relative.slice(1, 0, 3).select(2, 3),
                                joints[s.parents[j]], weight);
  }
  // Rest -> canonical with the canonical frame's transforms.
  const auto rest_joints = torch::stack(joints);  // [J, 3]
  s.joints = transform_points(canonical.bone_transforms_rest.to(torch::kFloat64), rest_joints).to(torch::kFloat32);
  return s;
}

DatasetBatchSource::DatasetBatchSource(const Dataset& dataset)
    : dataset_(dataset), skeleton_(canonical_skeleton(dataset)) {}

OccupancyBatch DatasetBatchSource::batch(int64_t frames, int64_t surface_points, int64_t uniform_points,
                                         uint64_t seed) const {
  Rng rng(seed);
  auto b = dataset_.sample_batch(frames, surface_points, uniform_points, rng);
  return {b.points, b.occupancy, b.bone_transforms.to(torch::kFloat32), b.pose.to(torch::kFloat32)};
}

std::vector<OccupancyFrame> evaluation_frames(const Dataset& dataset) {
  std::vector<OccupancyFrame> frames;
  for (int64_t i = 0; i < dataset.size(); ++i) {
    const auto& f = dataset.frame(i);
    frames.push_back({f.points, f.occupancy.to(torch::kFloat32), f.num_uniform, f.bone_transforms, f.pose});
  }
  return frames;
}

}  // namespace fskin
