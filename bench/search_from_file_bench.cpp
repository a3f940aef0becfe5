// The Fast-SNARF search on a scene read from an .npz (grid [D, H, W, J],
// corners [2, 3] of the box fitted with 24 voxels along the longest side,
// canonical points [1, N, 3], bones [1, J, 4, 4]), so that another caller —
// python/bench/search_overhead.py, through the Python module — can time the
// same search on the same data and report its overhead against C++.
// FSKIN_BENCH_SEARCH_INPUT names the file; without it the benchmark skips.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <cstdlib>
#include <thread>

#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/geometry/voxel_box.h"
#include "fskin/io/npz.h"

namespace {

void BM_FastSnarfSearchFromFile(benchmark::State& state) {
  const char* path = std::getenv("FSKIN_BENCH_SEARCH_INPUT");
  if (!path || !*path) {
    state.SkipWithError("set FSKIN_BENCH_SEARCH_INPUT to a scene .npz (python/bench/search_overhead.py writes one)");
    return;
  }
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));  // as the CLI
  torch::NoGradGuard no_grad;
  const fskin::io::NpzReader npz(path);
  const auto box = fskin::VoxelBox::fit(npz.tensor("corners"), 24, 0.05);
  const auto field = std::make_shared<fskin::FrozenSkinningField>(npz.tensor("grid"), box);
  fskin::FastSnarfDeformer deformer(field);
  const auto bones = npz.tensor("bones");
  const auto posed = deformer.deform(npz.tensor("canonical"), bones);
  for (auto _ : state) benchmark::DoNotOptimize(deformer.forward(posed, bones).valid);
  state.counters["points"] = static_cast<double>(posed.size(1));
}
BENCHMARK(BM_FastSnarfSearchFromFile)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
