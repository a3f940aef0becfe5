// fskin animate: a glTF animation (.glb / .gltf) from mesh frames or from a
// model posed by a pose file, for Blender, three.js and other viewers; or,
// from a trained run, one mesh per pose (MISE in every pose, the per-frame
// cost of SNARF / Fast-SNARF).
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "cli/commands.h"
#include "cli/meshing_options.h"
#include "fskin/body/body_model.h"
#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/data/pose_set.h"
#include "fskin/export/gltf_animation.h"
#include "fskin/export/palette.h"
#include "fskin/io/mesh_io.h"
#include "fskin/inference/posed_meshing.h"
#include "fskin/inference/trained_run.h"
#include "fskin/engine/run_directory.h"
#include "fskin/util/atomic_file.h"

namespace fskin::cli {
namespace {

// What both run modes start from: the run, its meshing settings, the poses'
// bone transforms (as the dataset computed them) and the output directory.
struct RunPoses {
  TrainedRun run;
  PosedMeshingOptions options;
  PoseSet poses;
  torch::Tensor bones;  // [N, J, 4, 4]

  static RunPoses load(const std::string& run_dir, const std::string& pose_path, const std::string& data,
                       const std::string& body_model, const MeshingFlags& flags, const std::string& out) {
    const auto device = check_meshing_flags(flags);
    RunPoses r{TrainedRun::load(run_dir, data, {}, device), {}, PoseSet::load(pose_path), {}};
    r.options = meshing_options(flags, r.run.config);
    r.bones = DatasetPosing::load(r.run.data_dir, body_model).bone_transforms(r.poses, pose_path);
    create_output_directory(out);
    return r;
  }
};

// Re-posing: the canonical mesh once (MISE), coloured by arg-max skinning bone,
// then every pose by moving its vertices (INS eq. 19): DIR/canonical.ply,
// DIR/frame_0000.ply ..., DIR/animation.glb (one mesh, a morph target per
// frame) and DIR/meshing.json.
void repose_run_poses(const std::string& run_dir, const std::string& pose_path, const std::string& data,
                      const std::string& body_model, const MeshingFlags& flags, const std::string& out, double fps,
                      bool quiet) {
  namespace fs = std::filesystem;
  auto loaded = RunPoses::load(run_dir, pose_path, data, body_model, flags, out);
  auto& run = loaded.run;
  const auto& bones = loaded.bones;
  auto canonical = mesh_canonical(*run.model, run.skeleton, run.canonical_pose, loaded.options);
  FSKIN_CHECK(canonical.mesh.num_faces() > 0, "animate: {} has an empty canonical surface", run_dir);
  if (auto* field = run.model->canonical_skinning_field()) {
    torch::NoGradGuard no_grad;
    canonical.mesh.colors =
        color_by_argmax_weight(field->weights(canonical.mesh.vertices.to(module_device(*field))).cpu());
  }
  io::write_mesh((fs::path(out) / "canonical.ply").string(), canonical.mesh);
  const auto start = std::chrono::steady_clock::now();
  const auto frames = repose_vertices(*run.model, canonical.mesh, bones, 8, !quiet);
  const double repose_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (int64_t n = 0; n < frames.size(0); ++n) {
    io::write_mesh((fs::path(out) / fmt::format("frame_{:04d}.ply", n)).string(),
                   Mesh{frames[n].contiguous(), canonical.mesh.faces, canonical.mesh.colors});
  }
  MeshAnimation animation;
  animation.fps = fps;
  animation.frames = frames;
  animation.faces = canonical.mesh.faces;
  animation.colors = canonical.mesh.colors;
  write_gltf_animation((fs::path(out) / "animation.glb").string(), animation);
  const double per_pose = repose_seconds / static_cast<double>(frames.size(0));
  const nlohmann::json summary = {{"run", run_dir},
                                  {"method", run.config.method},
                                  {"step", run.step},
                                  {"poses", pose_path},
                                  {"mode", "repose"},
                                  {"canonical_meshing_seconds", canonical.seconds},
                                  {"canonical_vertices", canonical.mesh.num_vertices()},
                                  {"repose_seconds", repose_seconds},
                                  {"seconds_per_pose", per_pose}};
  write_file_atomically((fs::path(out) / "meshing.json").string(), summary.dump(2) + "\n");
  std::printf("wrote %lld re-posed meshes of %lld vertices and animation.glb to %s (%s, step %lld)\n"
              "canonical mesh %.2f s once, then %.4f s per pose (%.1f poses/s)\n",
              static_cast<long long>(frames.size(0)), static_cast<long long>(canonical.mesh.num_vertices()),
              out.c_str(), run.config.method.c_str(), static_cast<long long>(run.step), canonical.seconds, per_pose,
              1.0 / per_pose);
}

// DIR/frame_0000.ply ... and DIR/meshing.json (seconds and samples per pose).
void mesh_run_poses(const std::string& run_dir, const std::string& pose_path, const std::string& data,
                    const std::string& body_model, const MeshingFlags& flags, const std::string& out, bool quiet) {
  namespace fs = std::filesystem;
  auto loaded = RunPoses::load(run_dir, pose_path, data, body_model, flags, out);
  auto& run = loaded.run;
  const auto& options = loaded.options;
  const auto& bones = loaded.bones;
  const auto& poses = loaded.poses;
  nlohmann::json frames = nlohmann::json::array();
  std::vector<double> seconds;
  int64_t evaluated = 0, dense = 0;
  mesh_pose_sequence(
      *run.model, run.skeleton, bones, poses.poses, options,
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
      !quiet);
  const auto n = static_cast<double>(seconds.size());
  double total = 0;
  for (double s : seconds) total += s;
  const nlohmann::json summary = {{"run", run_dir},
                                  {"method", run.config.method},
                                  {"step", run.step},
                                  {"poses", pose_path},
                                  {"resolution", options.mise.final_resolution()},
                                  {"initial_resolution", options.mise.initial_resolution},
                                  {"seconds_per_pose", total / n},
                                  {"frames", frames}};
  write_file_atomically((fs::path(out) / "meshing.json").string(), summary.dump(2) + "\n");
  std::printf("wrote %zu meshes to %s (%s, step %lld, MISE %lld -> %lld)\n"
              "%.2f s per pose (min %.2f, max %.2f); %.0f of %.0f samples evaluated per pose (%.1f %%)\n",
              seconds.size(), out.c_str(), run.config.method.c_str(), static_cast<long long>(run.step),
              static_cast<long long>(options.mise.initial_resolution),
              static_cast<long long>(options.mise.final_resolution()), total / n,
              *std::min_element(seconds.begin(), seconds.end()), *std::max_element(seconds.begin(), seconds.end()),
              static_cast<double>(evaluated) / n, static_cast<double>(dense) / n,
              100.0 * static_cast<double>(evaluated) / static_cast<double>(dense));
}

}  // namespace

void register_animate(CLI::App& app) {
  struct Options {
    std::vector<std::string> meshes;
    std::string model, pose, out, run, run_poses, data;
    double fps = 30;
    bool color_by_bone = false, quiet = false, repose = false, per_pose = false;
    MeshingFlags meshing;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand(
      "animate",
      "Write a glTF animation (.glb or .gltf) from mesh frames or a posed model; or, with a trained run, "
      "one mesh per pose (DIR/frame_0000.ply ...)");
  auto* run = cmd->add_option("run", opt->run, "trained run directory (with --poses): mesh every pose");
  auto* meshes = cmd->add_option("--mesh", opt->meshes,
                                 "mesh frames in order (.ply or .obj, same faces); repeat");
  auto* model = cmd->add_option("--model", opt->model,
                                "SMPL-format model .npz (with --pose, or for --color-by-bone; with RUN: the "
                                "dataset's body model, default the manifest's)");
  cmd->add_option("--pose", opt->pose, "pose file .npz (N, J, 3): one frame per pose")
      ->needs(model)
      ->excludes(meshes);
  cmd->add_flag("--color-by-bone", opt->color_by_bone,
                "colour vertices by the model's arg-max skinning bone")
      ->needs(model);
  auto* run_poses = cmd->add_option("--poses", opt->run_poses, "with RUN: pose file .npz (N, J, 3), one mesh each")
                       ->needs(run)
                       ->excludes(meshes);
  run->needs(run_poses);
  cmd->add_option("--data", opt->data, "with RUN: dataset directory (default: the one the run trained on)")
      ->needs(run);
  auto* repose = cmd->add_flag("--repose", opt->repose,
                               "with RUN: mesh the canonical shape once and move its vertices into every pose "
                               "(default for ins runs; exact correspondences, ignores pose-conditioned shape)")
                     ->needs(run);
  cmd->add_flag("--per-pose", opt->per_pose, "with RUN: extract a new mesh in every pose (default except for ins)")
      ->needs(run)
      ->excludes(repose);
  cmd->add_option("--out", opt->out, "output .glb (binary) or .gltf (JSON); with RUN: output directory")
      ->required();
  cmd->add_option("--fps", opt->fps, "frames per second")->check(CLI::PositiveNumber);
  auto* meshing = cmd->add_option_group("meshing", "with RUN: MISE settings");
  add_meshing_flags(*meshing, opt->meshing);
  cmd->add_flag("--quiet", opt->quiet, "no progress bar");
  cmd->callback([opt] {
    if (!opt->run.empty()) {
      FSKIN_CHECK(opt->pose.empty() && !opt->color_by_bone,
                  "animate RUN --poses: --pose and --color-by-bone belong to the glTF modes");
      const auto method = TrainConfig::load_run(RunDirectory(opt->run).config_file()).method;
      if (opt->repose || (method == "ins" && !opt->per_pose)) {
        repose_run_poses(opt->run, opt->run_poses, opt->data, opt->model, opt->meshing, opt->out, opt->fps,
                         opt->quiet);
      } else {
        mesh_run_poses(opt->run, opt->run_poses, opt->data, opt->model, opt->meshing, opt->out, opt->quiet);
      }
      return;
    }
    FSKIN_CHECK(!opt->meshes.empty() || !opt->pose.empty(),
                "animate: give mesh frames (--mesh ...) or --model with --pose");
    MeshAnimation animation;
    animation.fps = opt->fps;
    std::optional<BodyModel> body;
    if (!opt->model.empty()) body = BodyModel::load(opt->model);
    if (!opt->pose.empty()) {
      const auto poses = PoseSet::load(opt->pose);
      poses.validate(opt->pose, body->num_joints(), body->data().joint_names);
      animation.frames = body->pose(poses.poses, {}, poses.trans, poses.joint_translations).vertices;
      animation.faces = body->data().faces;
    } else {
      std::vector<torch::Tensor> frames;
      for (const auto& path : opt->meshes) {
        const Mesh mesh = io::read_mesh(path);
        if (frames.empty()) {
          animation.faces = mesh.faces;
          animation.colors = mesh.colors;
        }
        FSKIN_CHECK(torch::equal(mesh.faces, animation.faces),
                    "animate: {} has other faces than {}", path, opt->meshes.front());
        frames.push_back(mesh.vertices);
      }
      animation.frames = torch::stack(frames);
    }
    if (opt->color_by_bone) {
      FSKIN_CHECK(body->num_vertices() == animation.frames.size(1),
                  "animate: --color-by-bone: {} has {} vertices, the frames {}", opt->model,
                  body->num_vertices(), animation.frames.size(1));
      animation.colors = color_by_argmax_weight(body->data().weights);
    }
    write_gltf_animation(opt->out, animation);
    std::printf("wrote %s (%lld frames of %lld vertices at %g fps)\n", opt->out.c_str(),
                static_cast<long long>(animation.num_frames()),
                static_cast<long long>(animation.frames.size(1)), animation.fps);
  });
}

}  // namespace fskin::cli
