// fskin animate: a glTF animation (.glb / .gltf) from mesh frames or from a
// model posed by a pose file, for Blender, three.js and other viewers.
#include <torch/torch.h>

#include <cstdio>
#include <optional>

#include "cli/commands.h"
#include "fskin/body/body_model.h"
#include "fskin/core/error.h"
#include "fskin/data/pose_set.h"
#include "fskin/export/gltf_animation.h"
#include "fskin/export/palette.h"
#include "fskin/io/mesh_io.h"

namespace fskin::cli {

void register_animate(CLI::App& app) {
  struct Options {
    std::vector<std::string> meshes;
    std::string model, pose, out;
    double fps = 30;
    bool color_by_bone = false;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand(
      "animate", "Write a glTF animation (.glb or .gltf) from mesh frames or a posed model");
  auto* meshes = cmd->add_option("--mesh", opt->meshes,
                                 "mesh frames in order (.ply or .obj, same faces); repeat");
  auto* model = cmd->add_option("--model", opt->model,
                                "SMPL-format model .npz (with --pose, or for --color-by-bone)");
  cmd->add_option("--pose", opt->pose, "pose file .npz (N, J, 3): one frame per pose")
      ->needs(model)
      ->excludes(meshes);
  cmd->add_flag("--color-by-bone", opt->color_by_bone,
                "colour vertices by the model's arg-max skinning bone")
      ->needs(model);
  cmd->add_option("--out", opt->out, "output .glb (binary) or .gltf (JSON)")->required();
  cmd->add_option("--fps", opt->fps, "frames per second")->check(CLI::PositiveNumber);
  cmd->callback([opt] {
    FSKIN_CHECK(!opt->meshes.empty() || !opt->pose.empty(),
                "animate: give mesh frames (--mesh ...) or --model with --pose");
    MeshAnimation animation;
    animation.fps = opt->fps;
    std::optional<BodyModel> body;
    if (!opt->model.empty()) body = BodyModel::load(opt->model);
    if (!opt->pose.empty()) {
      const auto poses = PoseSet::load(opt->pose);
      poses.validate(opt->pose, body->num_joints(), body->data().joint_names);
      animation.frames = body->pose(poses.poses, {}, poses.trans).vertices;
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
