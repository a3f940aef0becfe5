// Pictures and animation files of the built-in character: software rendering
// (the demo's contact sheets) and glTF animation export.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <filesystem>
#include <thread>

#include "fskin/body/character.h"
#include "fskin/export/gltf_animation.h"
#include "fskin/export/palette.h"
#include "fskin/export/render.h"

namespace {

const fskin::BodyModel& character() {
  static const fskin::BodyModel model = fskin::make_character_model({});
  return model;
}

// One 512 x 512 picture with 3 x 3 supersampling of the character (~20k faces).
void BM_RenderCharacter(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  fskin::Mesh mesh = character().template_mesh();
  mesh.colors = fskin::color_by_argmax_weight(character().data().weights);
  fskin::RenderOptions options;
  options.view = fskin::view_angles(fskin::View::ThreeQuarter);
  for (auto _ : state) {
    auto image = fskin::render_mesh(mesh, options);
    benchmark::DoNotOptimize(image.rgb.data());
  }
  state.counters["faces"] = static_cast<double>(mesh.num_faces());
}
BENCHMARK(BM_RenderCharacter)->Unit(benchmark::kMillisecond);

// 30 posed frames of the character written as one .glb.
void BM_WriteGltfAnimation(benchmark::State& state) {
  torch::manual_seed(0);
  const auto& model = character();
  fskin::MeshAnimation animation;
  animation.faces = model.data().faces;
  animation.frames = model.pose(torch::randn({30, model.num_joints(), 3}) * 0.2).vertices;
  const auto path =
      (std::filesystem::temp_directory_path() / "fskin_bench_animation.glb").string();
  for (auto _ : state) fskin::write_gltf_animation(path, animation);
  state.counters["MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  std::filesystem::remove(path);
}
BENCHMARK(BM_WriteGltfAnimation)->Unit(benchmark::kMillisecond);

}  // namespace
