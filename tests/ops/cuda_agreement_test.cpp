// The CUDA kernels against the CPU kernels they share their cores with: the
// Fast-SNARF search (grid precompute, Broyden, duplicate filter) gives the
// same roots and validity, and the implicit gradients agree; each fused op on
// its own (grid skinning, duplicate filter, SNARF's Broyden lanes, the PIN
// pass, the hash encoding, ray compositing, the Gaussian rasteriser); bad
// inputs are errors on CUDA too; training on CUDA follows the CPU
// and its checkpoints load on the CPU. Skipped where no CUDA device exists
// (every CPU machine, CI); scripts/gpu_check.sh runs them on a GPU machine.
#include <gtest/gtest.h>
#include <torch/cuda.h>
#include <torch/torch.h>

#include "deformers/synthetic_chain.h"
#include "fskin/core/error.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/deformers/snarf_deformer.h"
#include "fskin/evaluation/evaluation.h"
#include "fskin/ops/filter_duplicate_roots.h"
#include "fskin/ops/gaussian_rasterization.h"
#include "fskin/ops/grid_forward_skinning.h"
#include "fskin/ops/hash_encoding.h"
#include "fskin/ops/pin_pass.h"
#include "fskin/ops/ray_compositing.h"
#include "fskin/training/occupancy_training.h"
#include "invertible/invertible_test_util.h"
#include "test_util.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

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

TEST_P(CudaAgreement, GridForwardSkinningMatchesTheCpu) {
  const auto dtype = GetParam();
  torch::manual_seed(2);
  const auto box = chain_box();
  const auto grid = torch::randn({2, box.shape.depth, box.shape.height, box.shape.width, 12}, dtype);
  // Inside and outside the box (border clamping).
  const auto x = (torch::rand({2, 5000, 3}, dtype) * 4 - 2).contiguous();
  const auto a = grid_forward_skinning(grid, box, x);
  const auto b = grid_forward_skinning(grid.to(torch::kCUDA), box, x.to(torch::kCUDA)).cpu();
  const double tolerance = dtype == torch::kFloat64 ? 1e-12 : 1e-5;
  EXPECT_LT((a - b).abs().max().item<double>(), tolerance * std::max(1.0, a.abs().max().item<double>()));
}

TEST_P(CudaAgreement, DuplicateFilterMatchesTheCpu) {
  const auto dtype = GetParam();
  torch::manual_seed(3);
  // Candidates on a coarse lattice, so many coincide exactly and some nearly.
  auto x = (torch::randint(0, 3, {2, 3000, 9, 3}) * 1e-4).to(dtype);
  x = x + torch::randn_like(x) * 1e-6;
  const auto valid = torch::rand({2, 3000, 9}) > 0.2;
  const auto a = filter_duplicate_roots(x, valid, 1e-4);
  const auto b = filter_duplicate_roots(x.to(torch::kCUDA), valid.to(torch::kCUDA), 1e-4).cpu();
  EXPECT_TRUE(torch::equal(a, b));
  EXPECT_LT(a.sum().item<int64_t>(), valid.sum().item<int64_t>());  // it removed some
}

TEST_P(CudaAgreement, SnarfBroydenLanesMatchTheCpu) {
  const auto dtype = GetParam();
  torch::manual_seed(4);
  const auto field = chain_field(dtype);
  auto on_gpu = std::make_shared<FrozenSkinningField>(field->grid_weights().to(torch::kCUDA), field->box());
  SnarfDeformer cpu(field), cuda(on_gpu);
  const auto bones = chain_bones(0.8, 0.5, 0.0, dtype);
  FastSnarfDeformer poser(field);
  const auto posed = poser.deform(chain_points(3000, dtype), bones).detach();
  torch::NoGradGuard no_grad;
  const auto a = cpu.forward(posed, bones);
  const auto b = cuda.forward(posed.to(torch::kCUDA), bones.to(torch::kCUDA));
  EXPECT_LE(b.valid.cpu().ne(a.valid).sum().item<int64_t>(), a.valid.numel() / 1000);
  const auto both = b.valid.cpu().logical_and(a.valid);
  const double tolerance = dtype == torch::kFloat64 ? 1e-9 : 1e-5;
  EXPECT_LT((b.x_canonical.cpu() - a.x_canonical).abs().amax(-1).masked_select(both).max().item<double>(), tolerance);
}

TEST_P(CudaAgreement, BadInputsAreErrorsOnCudaToo) {
  const auto dtype = GetParam();
  auto pair = deformers(dtype);
  const auto bones = chain_bones(0.8, 0.5, 0.0, dtype).to(torch::kCUDA);
  auto x = chain_points(100, dtype).to(torch::kCUDA);
  x[0][7][1] = std::numeric_limits<double>::quiet_NaN();
  testing::expect_error([&] { pair.cuda.forward(x, bones); }, {"Deformer::forward: x_posed: 1 non-finite"});
  auto singular = bones.clone();
  singular[0][1].narrow(0, 0, 3).fill_(0.0);
  testing::expect_error([&] { pair.cuda.forward(chain_points(100, dtype).to(torch::kCUDA), singular); },
                        {"singular"});
}

INSTANTIATE_TEST_SUITE_P(Dtypes, CudaAgreement, ::testing::Values(torch::kFloat32, torch::kFloat64),
                         [](const auto& info) { return info.param == torch::kFloat32 ? "float32" : "float64"; });

class CudaOnly : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  }
};

TEST_F(CudaOnly, PinPassMatchesTheCpu) {
  torch::manual_seed(5);
  PinOptions o;
  o.num_layers = 7;
  o.own_pose_encoder = false;
  o.coupling.embedding_dim = 10;
  o.coupling.space_hidden_dim = 24;
  o.coupling.first_omega = 10;
  o.coupling.hidden_omega = 10;
  o.coupling.map_hidden_dim = 12;
  Pin pin(o);
  testing::randomize_parameters(*pin, 0.3);
  torch::NoGradGuard no_grad;
  const auto x = torch::rand({3, 4001, 3}) * 2 - 1;
  const auto pose = torch::randn({3, 10});
  for (const bool inverse : {false, true}) {
    const auto a = fused_pin_pass(*pin, x, pose, inverse);
    pin->to(torch::kCUDA);
    const auto b = fused_pin_pass(*pin, x.to(torch::kCUDA), pose.to(torch::kCUDA), inverse).cpu();
    pin->to(torch::kCPU);
    EXPECT_LT((a - b).abs().max().item<double>(), 1e-4 * std::max(1.0, a.abs().max().item<double>())) << inverse;
  }
}

TEST_F(CudaOnly, HashEncodingMatchesTheCpuForwardAndBackward) {
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    torch::manual_seed(6);
    HashEncodingOptions o;
    o.levels = 8;
    o.log2_table_size = 12;
    const auto positions = torch::rand({20000, 3}, dtype);
    const auto table = torch::randn({o.levels, o.table_size(), o.features_per_level}, dtype);
    const auto weights = torch::randn({20000, o.output_dim()}, dtype);
    const auto run = [&](const torch::Device device) {
      const auto p = positions.to(device).requires_grad_(true), t = table.to(device).requires_grad_(true);
      const auto out = hash_encoding(p, t, o);
      (out * weights.to(device)).sum().backward();
      return std::make_tuple(out.detach().cpu(), p.grad().cpu(), t.grad().cpu());
    };
    const auto [a_out, a_p, a_t] = run(torch::kCPU);
    const auto [b_out, b_p, b_t] = run(torch::kCUDA);
    const double tolerance = dtype == torch::kFloat64 ? 1e-10 : 1e-4;
    EXPECT_LT((a_out - b_out).abs().max().item<double>(), tolerance);
    // The table's sums arrive in another order (atomics): relative to their size.
    EXPECT_LT((a_t - b_t).abs().max().item<double>(), tolerance * std::max(1.0, a_t.abs().max().item<double>()));
    EXPECT_LT((a_p - b_p).abs().max().item<double>(), tolerance * std::max(1.0, a_p.abs().max().item<double>()));
  }
}

TEST_F(CudaOnly, RayCompositingMatchesTheCpuForwardAndBackward) {
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    torch::manual_seed(7);
    const auto sigma = torch::rand({5000, 48}, dtype) * 8, rgb = torch::rand({5000, 48, 3}, dtype);
    const auto delta = torch::rand({5000, 48}, dtype) * 0.05, background = torch::rand({5000, 3}, dtype);
    const auto run = [&](const torch::Device device) {
      const auto s = sigma.to(device).requires_grad_(true), c = rgb.to(device).requires_grad_(true);
      const auto [color, opacity] = composite_rays(s, c, delta.to(device), background.to(device));
      (color.sum() + 2 * opacity.sum()).backward();
      return std::make_tuple(color.detach().cpu(), s.grad().cpu(), c.grad().cpu());
    };
    const auto [a_color, a_s, a_c] = run(torch::kCPU);
    const auto [b_color, b_s, b_c] = run(torch::kCUDA);
    const double tolerance = dtype == torch::kFloat64 ? 1e-12 : 1e-5;
    EXPECT_LT((a_color - b_color).abs().max().item<double>(), tolerance);
    EXPECT_LT((a_s - b_s).abs().max().item<double>(), 10 * tolerance);
    EXPECT_LT((a_c - b_c).abs().max().item<double>(), tolerance);
  }
}

TEST_F(CudaOnly, GaussianRasterizationMatchesTheCpuForwardAndBackward) {
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    torch::manual_seed(8);
    const int64_t n = 3000, width = 93, height = 71;
    const auto means2d = torch::rand({n, 2}, dtype) * torch::tensor({width + 10.0, height + 10.0}, dtype) - 5;
    const auto sigma = 1 + 4 * torch::rand({n}, dtype);
    const auto conics = torch::stack({1 / (sigma * sigma), torch::zeros_like(sigma), 1 / (sigma * sigma)}, 1);
    const auto colors = torch::rand({n, 3}, dtype), opacities = torch::rand({n}, dtype);
    const auto depths = torch::rand({n}, dtype), radii = torch::ceil(3 * sigma);
    const auto background = torch::rand({3}, dtype);
    const auto run = [&](const torch::Device device) {
      const auto m = means2d.to(device).requires_grad_(true), c = colors.to(device).requires_grad_(true);
      const auto o = opacities.to(device).requires_grad_(true);
      const auto [image, alpha] = rasterize_gaussians(m, conics.to(device), c, o, depths.to(device), radii.to(device),
                                                      background.to(device), width, height);
      (image.sum() + 2 * alpha.sum()).backward();
      return std::make_tuple(image.detach().cpu(), m.grad().cpu(), c.grad().cpu(), o.grad().cpu());
    };
    const auto [a_image, a_m, a_c, a_o] = run(torch::kCPU);
    const auto [b_image, b_m, b_c, b_o] = run(torch::kCUDA);
    const double tolerance = dtype == torch::kFloat64 ? 1e-10 : 1e-4;
    EXPECT_LT((a_image - b_image).abs().max().item<double>(), tolerance);
    // Per-Gaussian sums arrive in another order on CUDA (atomics): relative to their size.
    for (const auto& [a, b] : {std::make_pair(a_m, b_m), std::make_pair(a_c, b_c), std::make_pair(a_o, b_o)}) {
      EXPECT_LT((a - b).abs().max().item<double>(), tolerance * std::max(1.0, a.abs().max().item<double>()));
    }
  }
}

// Training on CUDA takes the CPU's batches (sampled on the host): its losses
// follow the CPU's, and its checkpoint evaluates on the CPU as on the GPU.
TEST_F(CudaOnly, TrainingFollowsTheCpuAndItsCheckpointLoadsOnTheCpu) {
  const testing::SyntheticLimb limb(testing::training_angles());
  for (const std::string method : {"fast-snarf", "snarf", "ins"}) {
    TrainConfig config = testing::tiny_config();
    config.use_method(method);
    config.steps = 30;
    config.checkpoint_every = 30;
    const auto cpu_run = testing::temp_dir("cuda_train_cpu_" + method);
    const auto gpu_run = testing::temp_dir("cuda_train_gpu_" + method);
    train(config, limb, {cpu_run.string(), false, false, nullptr});
    TrainOptions on_gpu{gpu_run.string(), false, false, nullptr};
    on_gpu.device = torch::kCUDA;
    train(config, limb, on_gpu);
    const auto a = testing::log_column(cpu_run, "bce"), b = testing::log_column(gpu_run, "bce");
    ASSERT_EQ(a.size(), b.size()) << method;
    EXPECT_NEAR(a.front(), b.front(), 1e-4 * std::max(1.0, a.front())) << method;
    EXPECT_NEAR(testing::mean(a, 20, 30), testing::mean(b, 20, 30), 0.1 * testing::mean(a, 20, 30)) << method;
    const auto frames = testing::SyntheticLimb::frames({-1.0, 0.3}, 1000, 1000);
    auto on_cpu = load_trained_model(gpu_run.string(), limb.skeleton());
    const auto cpu_scores = evaluate(*on_cpu, frames, "test");
    on_cpu->to(torch::kCUDA);
    const auto gpu_scores = evaluate(*on_cpu, frames, "test");
    EXPECT_NEAR(cpu_scores.mean_iou_surf, gpu_scores.mean_iou_surf, 2e-3) << method;
    std::filesystem::remove_all(cpu_run);
    std::filesystem::remove_all(gpu_run);
  }
}

}  // namespace
}  // namespace fskin
