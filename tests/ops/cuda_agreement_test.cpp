// The CUDA kernels against the CPU kernels they share their cores with: the
// Fast-SNARF search (grid precompute, Broyden, duplicate filter) gives the
// same roots and validity, and the implicit gradients agree. Skipped where
// no CUDA device exists (every CPU machine, CI); scripts/gpu_check.sh runs
// them on a GPU machine.
#include <gtest/gtest.h>
#include <torch/cuda.h>
#include <torch/torch.h>

#include "deformers/synthetic_chain.h"
#include "fskin/deformers/fast_snarf_deformer.h"

namespace fskin {
namespace {

using namespace fskin::testing;

struct Pair {
  FastSnarfDeformer cpu, cuda;
};

Pair deformers(torch::Dtype dtype) {
  const auto field = chain_field(dtype);
  auto on_gpu = std::make_shared<FrozenSkinningField>(field->grid_weights().to(torch::kCUDA), field->box());
  return Pair{FastSnarfDeformer(field), FastSnarfDeformer(on_gpu)};
}

class CudaAgreement : public ::testing::TestWithParam<torch::Dtype> {
 protected:
  void SetUp() override {
    if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  }
};

TEST_P(CudaAgreement, FastSnarfRootsAndValidityMatchTheCpu) {
  const auto dtype = GetParam();
  torch::manual_seed(0);
  auto pair = deformers(dtype);
  for (const auto& bones : {chain_bones(0.8, 0.5, 0.0, dtype), chain_bones(-1.9, 1.6, 0.7, dtype)}) {
    const auto posed = pair.cpu.deform(chain_points(20000, dtype), bones);
    torch::NoGradGuard no_grad;
    const auto a = pair.cpu.forward(posed, bones);
    const auto b = pair.cuda.forward(posed.to(torch::kCUDA), bones.to(torch::kCUDA));
    const auto valid = b.valid.cpu();
    // Points near a convergence threshold may flip: at most 1 in 1000.
    EXPECT_LE(valid.ne(a.valid).sum().item<int64_t>(), a.valid.numel() / 1000);
    const auto both = valid.logical_and(a.valid);
    const double tolerance = dtype == torch::kFloat64 ? 1e-9 : 1e-5;
    const auto difference = (b.x_canonical.cpu() - a.x_canonical).abs().amax(-1).masked_select(both);
    EXPECT_LT(difference.max().item<double>(), tolerance);
  }
}

TEST_P(CudaAgreement, FastSnarfImplicitGradientsMatchTheCpu) {
  const auto dtype = GetParam();
  torch::manual_seed(1);
  auto pair = deformers(dtype);
  const auto bones = chain_bones(0.8, 0.5, 0.0, dtype);
  const auto posed = pair.cpu.deform(chain_points(4000, dtype), bones).detach();
  const auto gradient = [&](FastSnarfDeformer& deformer, const torch::Device device) {
    auto x = posed.to(device).requires_grad_(true);
    const auto out = deformer.forward(x, bones.to(device));
    const auto loss = (out.x_canonical * out.valid.unsqueeze(-1)).square().sum();
    loss.backward();
    return x.grad().cpu();
  };
  const auto a = gradient(pair.cpu, torch::kCPU), b = gradient(pair.cuda, torch::kCUDA);
  const double tolerance = dtype == torch::kFloat64 ? 1e-8 : 1e-3;
  EXPECT_LT((a - b).abs().max().item<double>(), tolerance * std::max(1.0, a.abs().max().item<double>()));
}

INSTANTIATE_TEST_SUITE_P(Dtypes, CudaAgreement, ::testing::Values(torch::kFloat32, torch::kFloat64),
                         [](const auto& info) { return info.param == torch::kFloat32 ? "float32" : "float64"; });

}  // namespace
}  // namespace fskin
