// fskin animate: a glTF animation (.glb / .gltf) from mesh frames or from a
// model posed by a pose file, for Blender, three.js and other viewers; or a
// trained run in every pose of a pose file (inference/run_animation.h).
#include <torch/torch.h>

#include <cstdio>
#include <optional>

#include "cli/commands.h"
#include "cli/meshing_options.h"
#include "fskin/body/body_model.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/data/pose_set.h"
#include "fskin/export/gltf_animation.h"
#include "fskin/export/palette.h"
#include "fskin/io/mesh_io.h"
#include "fskin/inference/run_animation.h"
#include "fskin/inference/trained_run.h"

namespace fskin::cli {
namespace {

// fskin animate RUN --poses FILE: the run, its meshing settings and the
// poses' bone transforms (as the run's dataset computes them) for the
// library's workflow (inference/run_animation.h).
void animate_run_poses(const std::string& run_dir, const std::string& pose_path, const std::string& data,
                       const std::string& body_model, const MeshingFlags& flags, const std::string& out,
                       RunAnimationMode mode, double fps, bool quiet) {
  const auto device = check_meshing_flags(flags);
  auto run = TrainedRun::load(run_dir, data, {}, device);
  const auto poses = PoseSet::load(pose_path);
  const auto bones = DatasetPosing::load(run.data_dir, body_model).bone_transforms(poses, pose_path);
  RunAnimationOptions options;
  options.mode = mode;
  options.meshing = meshing_options(flags, run.config);
  options.fps = fps;
  options.progress = !quiet;
  const auto result = animate_run(run, poses.poses, bones, pose_path, out, options);
  std::printf("%s\n", result.description.c_str());
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
      const auto mode = opt->repose     ? RunAnimationMode::Repose
                        : opt->per_pose ? RunAnimationMode::PerPose
                                        : RunAnimationMode::Default;
      animate_run_poses(opt->run, opt->run_poses, opt->data, opt->model, opt->meshing, opt->out, mode, opt->fps,
                        opt->quiet);
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
