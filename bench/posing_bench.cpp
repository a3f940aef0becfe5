// Posing an SMPL-format model: the cost of FK + pose correctives + LBS per pose.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <thread>

#include "fskin/body/body_model.h"

namespace {

// A synthetic SMPL-like model: V vertices, 24 joints, smooth random weights and
// full pose correctives, so the cost matches a real model of that size.
fskin::BodyModel synthetic_model(int64_t vertices) {
  torch::manual_seed(0);
  fskin::BodyModelData d;
  d.v_template = torch::randn({vertices, 3});
  d.faces = torch::randint(0, vertices, {2 * vertices, 3}, torch::kInt64);
  d.weights = torch::softmax(torch::randn({vertices, 24}) * 3, 1);
  d.J_regressor = torch::softmax(torch::randn({24, vertices}), 1);
  d.parents = {-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21};
  d.posedirs = torch::randn({vertices, 3, 9 * 23}) * 1e-3;
  return fskin::BodyModel(std::move(d), "synthetic");
}

void BM_PoseModel(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  torch::NoGradGuard no_grad;
  const auto model = synthetic_model(state.range(0));
  const int64_t batch = state.range(1);
  const auto poses = torch::randn({batch, 24, 3}) * 0.3;
  for (auto _ : state) {
    auto out = model.pose(poses);
    benchmark::DoNotOptimize(out.vertices.data_ptr<float>());
  }
  state.counters["poses/s"] =
      benchmark::Counter(static_cast<double>(batch), benchmark::Counter::kIsIterationInvariantRate);
}
// 10k vertices, 1,000 poses in batches of 100 and in one batch.
BENCHMARK(BM_PoseModel)->Args({10000, 100})->Args({10000, 1000})->Unit(benchmark::kMillisecond);

}  // namespace
