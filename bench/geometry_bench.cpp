// Meshing: marching cubes on an analytic field, and generating the built-in character.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <thread>

#include "fskin/body/character.h"
#include "fskin/geometry/iso_surface.h"
#include "fskin/geometry/nearest_vertex.h"

namespace {

// n^3 samples of a sphere's signed distance over [-1, 1]^3 (sampling not timed).
void BM_IsoSurfaceSphere(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  const int64_t n = state.range(0);
  const double h = 2.0 / static_cast<double>(n - 1);
  const fskin::GridBox box{{-1, -1, -1}, {h, h, h}};
  const auto grid =
      fskin::sample_grid([](const torch::Tensor& p) { return p.norm(2, 1) - 0.8; }, box, {n, n, n});
  int64_t faces = 0;
  for (auto _ : state) {
    const auto mesh = fskin::iso_surface(grid, box, fskin::IsoSurfaceOptions{0.0, false});
    faces = mesh.num_faces();
    benchmark::DoNotOptimize(mesh.faces.data_ptr<int64_t>());
  }
  state.counters["faces"] = static_cast<double>(faces);
}
BENCHMARK(BM_IsoSurfaceSphere)->Arg(64)->Arg(128)->Arg(256)->Unit(benchmark::kMillisecond);

// The nearest vertex of every centre of the papers' 16 x 64 x 64 voxel grid on
// the built-in body (the preset skinning grid's query): the k-d tree
// (state.range(0) = 1) against a chunked brute-force distance matrix (0).
void BM_NearestVertexOfVoxelCentres(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  fskin::CharacterOptions options;
  const auto vertices = fskin::make_character(options).v_template.to(torch::kFloat32);
  const auto lo = std::get<0>(vertices.min(0)), hi = std::get<0>(vertices.max(0));
  const auto axis = [&](int a, int64_t n) { return torch::linspace(lo[a].item<float>(), hi[a].item<float>(), n); };
  const auto grid = torch::meshgrid({axis(2, 16), axis(1, 64), axis(0, 64)}, "ij");
  const auto centres = torch::stack({grid[2], grid[1], grid[0]}, -1).reshape({-1, 3}).contiguous();
  const bool tree = state.range(0) == 1;
  for (auto _ : state) {
    if (tree) {
      benchmark::DoNotOptimize(fskin::nearest_vertices(centres, vertices).index.data_ptr<int64_t>());
    } else {
      for (int64_t s = 0; s < centres.size(0); s += 1024) {
        const auto chunk = centres.narrow(0, s, std::min<int64_t>(1024, centres.size(0) - s));
        benchmark::DoNotOptimize(torch::cdist(chunk, vertices).argmin(1).data_ptr<int64_t>());
      }
    }
  }
  state.counters["queries"] = static_cast<double>(centres.size(0));
  state.counters["vertices"] = static_cast<double>(vertices.size(0));
}
BENCHMARK(BM_NearestVertexOfVoxelCentres)->ArgName("kd_tree")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The whole model: field, meshing, clean-up, regressor, weights, correctives.
void BM_MakeCharacter(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  fskin::CharacterOptions options;
  options.resolution = static_cast<int>(state.range(0));
  options.clothed = state.range(1) != 0;
  int64_t faces = 0;
  for (auto _ : state) {
    const auto data = fskin::make_character(options);
    faces = data.faces.size(0);
    benchmark::DoNotOptimize(data.v_template.data_ptr<float>());
  }
  state.counters["faces"] = static_cast<double>(faces);
}
BENCHMARK(BM_MakeCharacter)
    ->Args({56, 0})
    ->Args({110, 0})
    ->Args({110, 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace
