#include "fskin/inference/run_animation.h"

#include <fmt/format.h>
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <vector>

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/export/gltf_animation.h"
#include "fskin/export/palette.h"
#include "fskin/io/mesh_io.h"
#include "fskin/util/atomic_file.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// meshing.json's first keys, whatever the mode.
nlohmann::json summary_head(const TrainedRun& run, const std::string& label, const char* mode) {
  return {{"run", run.dir}, {"method", run.config.method}, {"step", run.step}, {"poses", label}, {"mode", mode}};
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RunAnimationResult repose(TrainedRun& run, const torch::Tensor& bones, const std::string& label,
                          const std::string& out, const RunAnimationOptions& options) {
  auto canonical = mesh_canonical(*run.model, run.skeleton, run.canonical_pose, options.meshing);
  FSKIN_CHECK(canonical.mesh.num_faces() > 0, "animate: {} has an empty canonical surface", run.dir);
  if (auto* field = run.model->canonical_skinning_field()) {
    torch::NoGradGuard no_grad;
    canonical.mesh.colors =
        color_by_argmax_weight(field->weights(canonical.mesh.vertices.to(module_device(*field))).cpu());
  }
  io::write_mesh((fs::path(out) / "canonical.ply").string(), canonical.mesh);
  const auto start = std::chrono::steady_clock::now();
  const auto frames = repose_vertices(*run.model, canonical.mesh, bones, options.repose_batch, options.progress);
  const double repose_seconds = seconds_since(start);
  for (int64_t n = 0; n < frames.size(0); ++n) {
    io::write_mesh((fs::path(out) / fmt::format("frame_{:04d}.ply", n)).string(),
                   Mesh{frames[n].contiguous(), canonical.mesh.faces, canonical.mesh.colors});
  }
  MeshAnimation animation;
  animation.fps = options.fps;
  animation.frames = frames;
  animation.faces = canonical.mesh.faces;
  animation.colors = canonical.mesh.colors;
  write_gltf_animation((fs::path(out) / "animation.glb").string(), animation);
  const double per_pose = repose_seconds / static_cast<double>(frames.size(0));
  RunAnimationResult result;
  result.mode = RunAnimationMode::Repose;
  result.summary = summary_head(run, label, "repose");
  result.summary.update({{"canonical_meshing_seconds", canonical.seconds},
                         {"canonical_vertices", canonical.mesh.num_vertices()},
                         {"repose_seconds", repose_seconds},
                         {"seconds_per_pose", per_pose}});
  result.description = fmt::format(
      "wrote {} re-posed meshes of {} vertices and animation.glb to {} ({}, step {})\n"
      "canonical mesh {:.2f} s once, then {:.4f} s per pose ({:.1f} poses/s)",
      frames.size(0), canonical.mesh.num_vertices(), out, run.config.method, run.step, canonical.seconds, per_pose,
      1.0 / per_pose);
  return result;
}

RunAnimationResult mesh_every_pose(TrainedRun& run, const torch::Tensor& poses, const torch::Tensor& bones,
                                   const std::string& label, const std::string& out,
                                   const RunAnimationOptions& options) {
  nlohmann::json frames = nlohmann::json::array();
  std::vector<double> seconds;
  int64_t evaluated = 0, dense = 0;
  mesh_pose_sequence(
      *run.model, run.skeleton, bones, poses, options.meshing,
      [&](int64_t n, MeshingResult&& result) {
        const auto file = fmt::format("frame_{:04d}.ply", n);
        io::write_mesh((fs::path(out) / file).string(), result.mesh);
        seconds.push_back(result.seconds);
        evaluated += result.stats.points_evaluated;
        dense += result.stats.dense_points;
        frames.push_back({{"file", file},
                          {"seconds", result.seconds},
                          {"field_seconds", result.stats.field_seconds},
                          {"points_evaluated", result.stats.points_evaluated},
                          {"dense_points", result.stats.dense_points},
                          {"vertices", result.mesh.num_vertices()},
                          {"faces", result.mesh.num_faces()}});
      },
      options.progress);
  const auto n = static_cast<double>(seconds.size());
  double total = 0;
  for (double s : seconds) total += s;
  const auto& mise = options.meshing.mise;
  RunAnimationResult result;
  result.mode = RunAnimationMode::PerPose;
  result.summary = summary_head(run, label, "per-pose");
  result.summary.update({{"resolution", mise.final_resolution()},
                         {"initial_resolution", mise.initial_resolution},
                         {"seconds_per_pose", total / n},
                         {"frames", frames}});
  result.description = fmt::format(
      "wrote {} meshes to {} ({}, step {}, MISE {} -> {})\n"
      "{:.2f} s per pose (min {:.2f}, max {:.2f}); {:.0f} of {:.0f} samples evaluated per pose ({:.1f} %)",
      seconds.size(), out, run.config.method, run.step, mise.initial_resolution, mise.final_resolution(), total / n,
      *std::min_element(seconds.begin(), seconds.end()), *std::max_element(seconds.begin(), seconds.end()),
      static_cast<double>(evaluated) / n, static_cast<double>(dense) / n,
      100.0 * static_cast<double>(evaluated) / static_cast<double>(dense));
  return result;
}

}  // namespace

RunAnimationResult animate_run(TrainedRun& run, const torch::Tensor& poses, const torch::Tensor& bones,
                               const std::string& label, const std::string& out, const RunAnimationOptions& options) {
  const auto joints = static_cast<int64_t>(run.skeleton.parents.size());
  expect_shape(bones, {-1, joints, 4, 4}, "animate: bone transforms");
  expect_shape(poses, {bones.size(0), joints, 3}, "animate: poses");
  FSKIN_CHECK(bones.size(0) > 0, "animate: {} holds no poses", label);
  FSKIN_CHECK(options.fps > 0 && options.repose_batch > 0, "animate: fps {} and repose_batch {} must be positive",
              options.fps, options.repose_batch);
  create_output_directory(out);
  const bool reposing = options.mode == RunAnimationMode::Repose ||
                        (options.mode == RunAnimationMode::Default && run.config.method == "ins");
  RunAnimationResult result = reposing ? repose(run, bones, label, out, options)
                                       : mesh_every_pose(run, poses, bones, label, out, options);
  write_file_atomically((fs::path(out) / "meshing.json").string(), result.summary.dump(2) + "\n");
  return result;
}

}  // namespace fskin
