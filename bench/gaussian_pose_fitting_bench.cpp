// Fitting training poses to their images with the Gaussians frozen
// (fit_gaussian_training_poses), what `--refine-poses` does to every frame of
// a run: range(1) frames, each seen by 4 cameras 90 degrees apart, 256 x 256,
// images the avatar rendered in the exact pose, each fit started from that
// pose turned by about 5 degrees per joint, 10 steps. range(0): Gaussians (a
// trained demo avatar holds about 29,000). Counter: frame steps per second
// (one step of one frame: its 4 views rendered and differentiated).
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <thread>

#include "fskin/body/body_model.h"
#include "fskin/body/character.h"
#include "fskin/export/render.h"
#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/gaussians/gaussian_pose_fitting.h"
#include "fskin/geometry/character_size.h"
#include "fskin/radiance/pose_correction.h"

namespace {

void BM_GaussianPoseFit(benchmark::State& state) {
  at::set_num_threads(static_cast<int>(std::thread::hardware_concurrency()));
  const auto character = fskin::make_character_model(fskin::CharacterOptions{}).rig();
  const auto& skeleton = character.skeleton;
  const double size = fskin::character_size(character.mesh.vertices);
  fskin::GaussianAvatarOptions options;
  options.initial_gaussians = state.range(0);
  torch::manual_seed(0);
  fskin::GaussianAvatar avatar(character, options, 0);
  {
    torch::NoGradGuard no_grad;  // coloured and opaque enough to fit against
    avatar->named_parameters()["sh_dc"].uniform_(-1, 1);
    avatar->named_parameters()["opacity_logits"].fill_(2);
  }
  const int64_t joints = character.num_joints(), views = 4, frames = state.range(1);
  const auto exact = torch::eye(4).repeat({joints, 1, 1});
  const std::array<double, 3> background{1, 1, 1};
  fskin::ImageSplit split;
  // Every frame the same pictures (the cost does not depend on which pose).
  split.images = torch::empty({frames * views, 256, 256, 3}, torch::kUInt8);
  split.masks = torch::empty({frames * views, 256, 256}, torch::kUInt8);
  split.bone_transforms = exact.unsqueeze(0).repeat({frames * views, 1, 1, 1});
  const auto box = fskin::bounding_box(character.mesh);
  std::vector<int64_t> frame_of;
  for (int64_t i = 0; i < frames * views; ++i) {
    frame_of.push_back(i / views);
    split.cameras.push_back(
        fskin::frame_camera(box, {90.0 * static_cast<double>(i % views), 10}, 256, 256, 30, 0.05));
    torch::NoGradGuard no_grad;
    const auto rendered = avatar->render(exact, split.cameras.back(), background);
    split.images[i].copy_((rendered.image * 255).round().clamp(0, 255).to(torch::kUInt8));
    split.masks[i].copy_((rendered.alpha * 255).round().clamp(0, 255).to(torch::kUInt8));
  }
  std::vector<torch::Tensor> noisy;
  for (int64_t f = 0; f < frames; ++f) {
    noisy.push_back(fskin::corrected_bone_transforms(exact, torch::randn({joints, 3}) * 0.087,
                                                     torch::randn({3}) * 0.01, skeleton, size));
  }
  fskin::PoseFittingOptions fitting;
  fitting.steps = 10;
  for (auto _ : state) {
    fskin::PoseCorrections corrections(torch::stack(noisy));
    fskin::fit_gaussian_training_poses(*avatar, split, frame_of, *corrections, nullptr, background, skeleton, size,
                                       0.5, fitting, false);
    benchmark::DoNotOptimize(corrections->rotations().data_ptr<float>());
  }
  state.counters["frame steps/s"] = benchmark::Counter(static_cast<double>(frames * fitting.steps),
                                                       benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_GaussianPoseFit)->Args({30000, 1})->Args({30000, 4})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
