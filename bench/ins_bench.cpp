// INS re-posing cost: one PIN inverse pass (eq. 14) over a mesh's vertices for
// one pose, the part of re-posing (two PIN inverses + LBS per pose, eq. 19)
// that dominates. Sine vs linear SIREN output (the linear one folds into the
// operation maps, operation_map.h), at the narrow widths of our clothed runs
// (maps 16 and maps 8, the default) and at the paper's.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <thread>

#include "fskin/ops/pin_pass.h"
#include "fskin/invertible/pin.h"

namespace {

// Args: vertices, coupling layers, SIREN width, map width, linear SIREN output (0/1),
// fused kernel (0: the LibTorch module, 1: fused_pin_pass).
void BM_PinInverse(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  torch::manual_seed(0);
  torch::NoGradGuard no_grad;
  fskin::PinOptions o;
  o.num_layers = state.range(1);
  o.coupling.space_hidden_dim = state.range(2);
  o.coupling.map_hidden_dim = state.range(3);
  o.coupling.space_linear_output = state.range(4) != 0;
  o.own_pose_encoder = false;
  fskin::Pin pin(o);
  // Off the identity initialisation, so the cost is that of a trained PIN.
  for (auto& p : pin->parameters()) p.add_(torch::randn_like(p) * 0.01);
  const auto vertices = torch::rand({1, state.range(0), 3}) * 2 - 1;
  const auto pose_embedding = torch::randn({1, o.coupling.embedding_dim});
  const bool fused = state.range(5) != 0;
  for (auto _ : state) {
    auto out = fused ? fskin::fused_pin_pass(*pin, vertices, pose_embedding, true)
                     : pin->inverse_embedded(vertices, pose_embedding);
    benchmark::DoNotOptimize(out.data_ptr<float>());
  }
  state.counters["vertices/s"] =
      benchmark::Counter(static_cast<double>(state.range(0)), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_PinInverse)
    ->ArgNames({"vertices", "layers", "siren", "map", "linear", "fused"})
    ->Args({50000, 6, 32, 16, 0, 0})
    ->Args({50000, 6, 32, 16, 1, 0})
    ->Args({50000, 6, 32, 16, 1, 1})
    ->Args({50000, 6, 32, 8, 1, 0})
    ->Args({50000, 6, 32, 8, 1, 1})
    ->Args({50000, 18, 64, 32, 0, 0})
    ->Args({50000, 18, 64, 32, 1, 0})
    ->Args({50000, 18, 64, 32, 1, 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace
