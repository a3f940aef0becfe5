// fskin export: a trained run's avatar as a rigged glTF 2.0 character (the
// canonical mesh, the learned skinning weights, the skeleton in the canonical
// pose, and optionally poses as an animation).
#include <torch/torch.h>

#include <cstdio>

#include "cli/commands.h"
#include "cli/meshing_options.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/data/pose_set.h"
#include "fskin/inference/posed_meshing.h"
#include "fskin/inference/rigged_avatar.h"
#include "fskin/inference/trained_run.h"

namespace fskin::cli {

void register_export(CLI::App& app) {
  struct Options {
    std::string run, out, clip, data, body_model;
    double fps = 30;
    MeshingFlags meshing;
  };
  auto opt = std::make_shared<Options>();
  opt->meshing.largest_component = true;
  auto* cmd = app.add_subcommand("export", "Export a trained run's avatar as a rigged glTF character (.glb/.gltf)");
  cmd->add_option("RUN", opt->run, "run directory (fast-snarf or snarf)")->required();
  cmd->add_option("--out", opt->out, "output .glb or .gltf")->required();
  cmd->add_option("--clip", opt->clip, "pose file .npz to include as the animation");
  cmd->add_option("--fps", opt->fps, "frames per second of the animation")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--data", opt->data, "dataset directory (default: the run's)");
  cmd->add_option("--body-model", opt->body_model, "model .npz the poses refer to (default: the dataset's)");
  add_meshing_flags(*cmd, opt->meshing);
  cmd->callback([opt] {
    check_meshing_flags(opt->meshing);
    const auto run = TrainedRun::load(opt->run, opt->data);
    torch::Tensor bones;
    if (!opt->clip.empty())
      bones = DatasetPosing::load(run.data_dir, opt->body_model).bone_transforms(PoseSet::load(opt->clip), opt->clip);
    const auto canonical = mesh_canonical(*run.model, run.skeleton, run.canonical_pose, meshing_options(opt->meshing, run.config));
    const auto avatar = rigged_avatar(*run.model, run.config.method, run.skeleton, canonical.mesh, bones, opt->fps);
    write_skinned_gltf(opt->out, avatar);
    std::printf("wrote %s: %lld vertices, %lld joints, 4 influences per vertex%s\n", opt->out.c_str(),
                static_cast<long long>(avatar.mesh.num_vertices()), static_cast<long long>(avatar.skeleton.num_joints()),
                avatar.animation.size() > 0
                    ? fmt::format(", {} poses at {} fps", avatar.animation.size(), opt->fps).c_str()
                    : "");
  });
}

}  // namespace fskin::cli
