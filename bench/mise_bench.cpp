// MISE against dense sampling + marching cubes on an analytic field (a sphere
// and a thin torus, logit-like: positive inside) over [-1, 1]^3, and MISE on
// the built-in character's occupancy (ray-cast inside test) in the box a
// posed model would be meshed in. The fields are cheap here, so the times
// show MISE's own bookkeeping; with a network the cost follows `evaluated`.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <thread>

#include "fskin/body/character.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/point_sampling.h"
#include "fskin/geometry/iso_surface.h"
#include "fskin/geometry/mise.h"

namespace {

torch::Tensor shapes(const torch::Tensor& p) {
  const auto sphere = 0.5 - (p - torch::tensor({0.1f, 0.2f, 0.0f})).norm(2, 1);
  const auto ring = torch::sqrt(p.select(1, 0).square() + p.select(1, 2).square()) - 0.7;
  const auto torus = 0.1 - torch::sqrt(ring.square() + (p.select(1, 1) + 0.5).square());
  return torch::maximum(sphere, torus);
}

void BM_MiseAnalytic(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  const auto options = fskin::MiseOptions::resolutions(32, state.range(0));
  fskin::MiseStats stats;
  int64_t faces = 0;
  for (auto _ : state) {
    const auto result = fskin::mise(shapes, {-1, -1, -1}, {1, 1, 1}, options);
    stats = result.stats;
    faces = result.mesh.num_faces();
  }
  state.counters["evaluated"] = static_cast<double>(stats.points_evaluated);
  state.counters["dense"] = static_cast<double>(stats.dense_points);
  state.counters["faces"] = static_cast<double>(faces);
}
BENCHMARK(BM_MiseAnalytic)->Arg(128)->Arg(256)->Unit(benchmark::kMillisecond);

void BM_DenseAnalytic(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  const int64_t n = state.range(0) + 1;
  const auto box = fskin::GridBox::spanning({-1, -1, -1}, {1, 1, 1}, {n, n, n});
  int64_t faces = 0;
  for (auto _ : state) faces = fskin::iso_surface(shapes, box, {n, n, n}).num_faces();
  state.counters["evaluated"] = static_cast<double>(n * n * n);
  state.counters["faces"] = static_cast<double>(faces);
}
BENCHMARK(BM_DenseAnalytic)->Arg(128)->Arg(256)->Unit(benchmark::kMillisecond);

// The T-posed character (1.7 m, ~20k faces), box = its bounds padded by 10 %
// of the longest side, as posed_meshing does.
void BM_MiseCharacter(benchmark::State& state) {
  if (!fskin::inside_test_available()) {
    state.SkipWithError("built without Embree");
    return;
  }
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  const auto mesh = fskin::make_character_model(fskin::CharacterOptions{}).template_mesh();
  const fskin::InsideTest inside(mesh);
  const fskin::ScalarField field = [&](const torch::Tensor& p) { return inside.contains(p).to(torch::kFloat32); };
  const auto bounds = fskin::mesh_bounds(mesh);
  std::array<double, 3> lo = bounds.min, hi = bounds.max;
  double longest = 0;
  for (int axis = 0; axis < 3; ++axis) longest = std::max(longest, hi[axis] - lo[axis]);
  for (int axis = 0; axis < 3; ++axis) {
    lo[axis] -= 0.1 * longest;
    hi[axis] += 0.1 * longest;
  }
  auto options = fskin::MiseOptions::resolutions(32, state.range(0));
  options.iso = 0.5;
  fskin::MiseStats stats;
  for (auto _ : state) stats = fskin::mise(field, lo, hi, options).stats;
  state.counters["evaluated"] = static_cast<double>(stats.points_evaluated);
  state.counters["dense"] = static_cast<double>(stats.dense_points);
  state.counters["field_s"] = stats.field_seconds;
}
BENCHMARK(BM_MiseCharacter)->Arg(128)->Arg(256)->Unit(benchmark::kMillisecond);

}  // namespace
