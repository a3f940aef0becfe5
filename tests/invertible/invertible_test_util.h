#pragma once
// Helpers for the invertible-network tests: parameters moved away from their
// identity initialisation, random rigid bones, per-point Jacobians and a
// finite-difference gradient check.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <functional>
#include <string>
#include <vector>

#include "fskin/skeleton/rotations.h"

namespace fskin::testing {

// Adds Gaussian noise to every parameter: `scale` times the parameter's own
// spread, or `scale` itself for constant (e.g. zero-initialised) parameters,
// so that every coupling layer is far from the identity.
inline void randomize_parameters(torch::nn::Module& module, double scale = 0.3) {
  torch::NoGradGuard no_grad;
  for (auto& p : module.parameters()) {
    const double spread = p.numel() > 1 ? p.std().item<double>() : 0.0;
    p.add_(torch::randn_like(p) * scale * (spread > 0 ? spread : 1.0));
  }
}

// Random rigid bone transforms [B, J, 4, 4]: rotations up to ~`angle` radians, translations ~0.3 m.
inline torch::Tensor random_bones(int64_t frames, int64_t bones, torch::Dtype dtype, double angle = 0.8) {
  const auto opts = torch::TensorOptions().dtype(dtype);
  auto t = torch::eye(4, opts).repeat({frames, bones, 1, 1});
  using torch::indexing::Slice;
  t.index_put_({Slice(), Slice(), Slice(0, 3), Slice(0, 3)},
               axis_angle_to_matrix(torch::randn({frames, bones, 3}, opts) * (angle / 1.7)));
  t.index_put_({Slice(), Slice(), Slice(0, 3), 3}, torch::randn({frames, bones, 3}, opts) * 0.3);
  return t;
}

inline torch::Tensor identity_bones(int64_t frames, int64_t bones, torch::Dtype dtype) {
  return torch::eye(4, torch::TensorOptions().dtype(dtype)).repeat({frames, bones, 1, 1});
}

// Per-point Jacobians d f(x)_i / d x_j [B, N, 3, 3] of a map that acts on
// each point separately (x [B, N, 3] -> [B, N, 3]), by three backward passes.
inline torch::Tensor point_jacobians(const std::function<torch::Tensor(const torch::Tensor&)>& f,
                                     const torch::Tensor& x) {
  const auto input = x.detach().requires_grad_(true);
  const auto y = f(input);
  std::vector<torch::Tensor> rows;
  for (int64_t i = 0; i < 3; ++i) {
    rows.push_back(torch::autograd::grad({y.select(-1, i).sum()}, {input}, {}, /*retain_graph=*/true)[0]);
  }
  return torch::stack(rows, -2);
}

// Compares autograd's d loss / d tensor at a few flat indices with central
// differences (float64). `tensor` must be a leaf that `loss` reads.
inline void expect_gradient_matches_finite_difference(const std::function<torch::Tensor()>& loss,
                                                      torch::Tensor tensor, const std::vector<int64_t>& indices,
                                                      const std::string& name, double eps = 1e-6,
                                                      double tolerance = 1e-6) {
  ASSERT_EQ(tensor.scalar_type(), torch::kFloat64) << name;
  const bool had_grad = tensor.requires_grad();
  tensor.requires_grad_(true);
  if (tensor.grad().defined()) tensor.mutable_grad().zero_();
  loss().backward();
  const auto analytic = tensor.grad().detach().flatten().clone();
  tensor.mutable_grad().zero_();
  for (int64_t i : indices) {
    ASSERT_LT(i, tensor.numel()) << name;
    double plus = 0, minus = 0, saved = 0;
    {
      torch::NoGradGuard no_grad;
      auto flat = tensor.view({-1});
      saved = flat[i].item<double>();
      flat[i].fill_(saved + eps);
      plus = loss().item<double>();
      flat[i].fill_(saved - eps);
      minus = loss().item<double>();
      flat[i].fill_(saved);
    }
    const double numeric = (plus - minus) / (2 * eps);
    const double a = analytic[i].item<double>();
    EXPECT_NEAR(a, numeric, tolerance * (1.0 + std::abs(numeric))) << name << "[" << i << "]";
  }
  tensor.requires_grad_(had_grad);
}

// Every parameter of `module` has a gradient with a non-zero entry.
inline void expect_all_parameters_have_gradient(torch::nn::Module& module) {
  for (const auto& p : module.named_parameters()) {
    ASSERT_TRUE(p.value().grad().defined()) << p.key() << " has no gradient";
    EXPECT_GT(p.value().grad().abs().max().item<double>(), 0.0) << p.key() << " has a zero gradient";
  }
}

}  // namespace fskin::testing
