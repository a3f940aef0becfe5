#pragma once
// A tiny articulated shape for training tests: two capsules (radius 0.15)
// along x, [-0.6, 0] on bone 0 and [0, 0.6] on bone 1 (bone 2 is the rigid tip
// joint at x = 0.6), bent by an elbow angle about z at the origin. Occupancy
// is analytic (inside either rigidly moved capsule), so frames are made in
// memory in milliseconds.
#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include <cmath>
#include <vector>

#include "fskin/skeleton/lbs.h"
#include "fskin/skeleton/rotations.h"
#include "fskin/evaluation/evaluation_frame.h"
#include "fskin/training/batch_source.h"

namespace fskin::testing {

class SyntheticLimb : public BatchSource {
 public:
  static constexpr double kRadius = 0.15;

  explicit SyntheticLimb(std::vector<double> angles) : angles_(std::move(angles)) {
    skeleton_.joint_names = {"root", "elbow", "tip"};
    skeleton_.parents = {-1, 0, 1};
    skeleton_.joints = torch::tensor({{-0.6f, 0.f, 0.f}, {0.f, 0.f, 0.f}, {0.6f, 0.f, 0.f}});
    skeleton_.extent = torch::tensor({{-0.75f, -0.15f, -0.15f}, {0.75f, 0.15f, 0.15f}});
  }

  int64_t num_frames() const override { return static_cast<int64_t>(angles_.size()); }
  const CanonicalSkeleton& skeleton() const override { return skeleton_; }

  static torch::Tensor bones(double angle) {
    const auto r = axis_angle_to_matrix(torch::tensor({0.0f, 0.0f, static_cast<float>(angle)}));
    const auto bent = make_transform(r, torch::zeros({3}));
    return torch::stack({torch::eye(4), bent, bent});
  }
  static torch::Tensor pose(double angle) {
    auto p = torch::zeros({3, 3});
    p[1][2] = angle;
    return p;
  }

  // Ground-truth occupancy of posed points [N, 3] at `angle` -> [N] float.
  static torch::Tensor occupancy(const torch::Tensor& x, double angle) {
    const auto b = bones(angle);
    auto inside_part = [&](int64_t bone, double lo, double hi) {
      const auto local = transform_points(invert_transforms(b[bone]), x);
      const auto t = local.select(1, 0).clamp(lo, hi);
      const auto d2 = (local.select(1, 0) - t).square() + local.select(1, 1).square() + local.select(1, 2).square();
      return d2 < kRadius * kRadius;
    };
    return (inside_part(0, -0.6, 0.0) | inside_part(1, 0.0, 0.6)).to(torch::kFloat32);
  }

  // `uniform` points in the posed box and `surface` points near the surface.
  static torch::Tensor sample_points(double angle, int64_t surface, int64_t uniform, at::Generator& g) {
    const auto lo = torch::tensor({-0.8f, -0.8f, -0.25f}), hi = torch::tensor({0.8f, 0.8f, 0.25f});
    const auto box_points = lo + torch::rand({uniform, 3}, g) * (hi - lo);
    const auto part = torch::randint(0, 2, {surface}, g);
    const auto along = torch::rand({surface}, g) * 0.6 - 0.6 + 0.6 * part.to(torch::kFloat32);
    auto direction = torch::randn({surface, 3}, g);
    direction = direction / direction.norm(2, 1, true);
    auto canonical = direction * kRadius + torch::randn({surface, 3}, g) * 0.02;
    canonical.select(1, 0).add_(along);
    const auto b = bones(angle);
    const auto posed = torch::where(part.unsqueeze(1) == 0, transform_points(b[0], canonical),
                                    transform_points(b[1], canonical));
    return torch::cat({box_points, posed});
  }

  OccupancyBatch batch(int64_t frames, int64_t surface_points, int64_t uniform_points,
                       uint64_t seed) const override {
    auto g = at::make_generator<at::CPUGeneratorImpl>(seed);
    std::vector<torch::Tensor> points, occ, bone_list, poses;
    const auto picks = torch::randint(0, num_frames(), {frames}, g);
    for (int64_t f = 0; f < frames; ++f) {
      const double angle = angles_[picks[f].item<int64_t>()];
      const auto x = sample_points(angle, surface_points, uniform_points, g);
      points.push_back(x);
      occ.push_back(occupancy(x, angle));
      bone_list.push_back(bones(angle));
      poses.push_back(pose(angle));
    }
    return {torch::stack(points), torch::stack(occ), torch::stack(bone_list), torch::stack(poses)};
  }

  // Evaluation frames at `angles`: `uniform` box points then `surface` near-surface ones.
  static std::vector<OccupancyFrame> frames(const std::vector<double>& angles, int64_t uniform, int64_t surface) {
    std::vector<OccupancyFrame> out;
    auto g = at::make_generator<at::CPUGeneratorImpl>(1234);
    for (double angle : angles) {
      const auto x = sample_points(angle, surface, uniform, g);
      out.push_back({x, occupancy(x, angle), uniform, bones(angle), pose(angle)});
    }
    return out;
  }

 private:
  std::vector<double> angles_;
  CanonicalSkeleton skeleton_;
};

}  // namespace fskin::testing
