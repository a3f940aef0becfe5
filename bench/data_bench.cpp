// Dataset building: surface/box sampling and the Embree inside test on the
// built-in character (~20k faces), 200k points per frame as in the papers.
#include <ATen/Parallel.h>
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include "fskin/body/character.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/point_sampling.h"

namespace {

const fskin::Mesh& character_mesh() {
  static const fskin::Mesh mesh = fskin::make_character_model({}).template_mesh();
  return mesh;
}

fskin::SamplingOptions frame_sampling() {
  fskin::SamplingOptions options;
  options.uniform_points = 100000;
  options.surface_points = 100000;
  return options;
}

void BM_SampleFramePoints(benchmark::State& state) {
  const auto& mesh = character_mesh();
  for (auto _ : state) {
    fskin::Rng rng(0);
    auto points = fskin::sample_frame_points(mesh, frame_sampling(), rng);
    benchmark::DoNotOptimize(points.data_ptr<float>());
  }
  state.counters["faces"] = static_cast<double>(mesh.num_faces());
}
BENCHMARK(BM_SampleFramePoints)->Unit(benchmark::kMillisecond);

void BM_InsideTestBuildHierarchy(benchmark::State& state) {
  if (!fskin::inside_test_available()) return state.SkipWithError("built without Embree");
  const auto& mesh = character_mesh();
  for (auto _ : state) {
    fskin::InsideTest test(mesh);
    benchmark::DoNotOptimize(&test);
  }
}
BENCHMARK(BM_InsideTestBuildHierarchy)->Unit(benchmark::kMillisecond);

// Argument: threads. 200k points of one frame.
void BM_InsideTest200k(benchmark::State& state) {
  if (!fskin::inside_test_available()) return state.SkipWithError("built without Embree");
  at::set_num_threads(static_cast<int>(state.range(0)));
  const auto& mesh = character_mesh();
  fskin::Rng rng(0);
  const auto points = fskin::sample_frame_points(mesh, frame_sampling(), rng);
  const fskin::InsideTest test(mesh);
  for (auto _ : state) {
    auto occupancy = test.contains(points);
    benchmark::DoNotOptimize(occupancy.data_ptr<uint8_t>());
  }
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(points.size(0)),
                                                  benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_InsideTest200k)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
