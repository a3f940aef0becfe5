// Fast-SNARF on the built-in character: the correspondence search (200k posed
// points, natural and extreme pose, 9 / all / automatic start bones) and the
// forward map of 50k canonical points (re-posing, meshing).
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <map>
#include <thread>

#include "fskin/body/character.h"
#include "fskin/benchmarking/character_scene.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/geometry/voxel_box.h"

namespace {

using fskin::ScenePose;

const fskin::CharacterScene& scene(ScenePose pose) {
  static const auto model = fskin::make_character_model(fskin::CharacterOptions{});
  static std::map<ScenePose, fskin::CharacterScene> scenes;
  auto it = scenes.find(pose);
  if (it == scenes.end()) it = scenes.emplace(pose, fskin::make_character_scene(model, pose)).first;
  return it->second;
}

// range(0): pose (0 natural, 1 extreme); range(1): starts (0 = SMPL 9, 1 = all, 2 = auto 4).
void BM_FastSnarfDeform(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  torch::NoGradGuard no_grad;
  const auto& s = scene(state.range(0) == 0 ? ScenePose::Natural : ScenePose::Extreme);
  auto options = fskin::DeformerOptions::fast_snarf();
  if (state.range(1) == 0) options.start_bones = fskin::StartBones::by_name(s.skeleton, fskin::StartBones::smpl_training_names());
  if (state.range(1) == 2) options.start_bones = fskin::StartBones::automatic(4);
  fskin::FastSnarfDeformer deformer(s.field, options);
  const int64_t n = 200000;
  const auto x = fskin::sample_query_points(s, n, 0);
  double search = 0, valid = 0, iterations = 0;
  for (auto _ : state) {
    const auto out = deformer.forward(x, s.bones);
    benchmark::DoNotOptimize(out.x_canonical.data_ptr<float>());
    search += out.stats.search_seconds;
    valid = out.stats.mean_valid;
    iterations = out.stats.mean_iterations;
  }
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["search_ms"] = 1e3 * search / static_cast<double>(state.iterations());
  state.counters["valid/pt"] = valid;
  state.counters["iters"] = iterations;
}
BENCHMARK(BM_FastSnarfDeform)
    ->ArgsProduct({{0, 1}, {0, 1, 2}})
    ->ArgNames({"extreme", "starts"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Forward LBS of 50k canonical surface points through the blended-transform
// grid (eq. 14-15). range(0): 0 = LibTorch (grid_sampler on the transform
// grid + a batched 3x3 product), 1 = Deformer::deform without gradients (the
// fused grid_forward_skinning kernel, plus blending the grid once, eq. 15).
void BM_FastSnarfForwardSkinning(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  torch::NoGradGuard no_grad;
  const auto& s = scene(ScenePose::Natural);
  fskin::FastSnarfDeformer deformer(s.field, fskin::DeformerOptions::fast_snarf());
  const int64_t n = 50000, J = s.bones.size(1);
  const auto x = fskin::sample_canonical_surface(s, n, 0.01, 0);
  const auto& box = s.field->box();
  const auto transforms = torch::matmul(s.field->grid_weights().reshape({1, -1, J}),
                                        s.bones.narrow(2, 0, 3).reshape({1, J, 12}))
                              .reshape({1, box.shape.depth, box.shape.height, box.shape.width, 12});
  for (auto _ : state) {
    torch::Tensor out;
    if (state.range(0) == 0) {
      const auto t = fskin::sample_voxels(transforms, box, x).reshape({1, n, 3, 4});
      out = torch::matmul(t.narrow(3, 0, 3), x.unsqueeze(-1)).squeeze(-1) + t.select(3, 3);
    } else {
      out = deformer.deform(x, s.bones);
    }
    benchmark::DoNotOptimize(out.data_ptr<float>());
  }
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_FastSnarfForwardSkinning)->Arg(0)->Arg(1)->ArgName("fused")->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
