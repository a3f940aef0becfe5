// fskin export: a trained run's avatar, or any SMPL-format model, as a rigged
// glTF 2.0 character (mesh, skinning weights, skeleton, and optionally poses
// as an animation).
#include <torch/torch.h>

#include <cstdio>
#include <fstream>

#include "cli/commands.h"
#include "cli/meshing_options.h"
#include "fskin/body/body_model.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/data/pose_set.h"
#include "fskin/inference/posed_meshing.h"
#include "fskin/inference/rigged_avatar.h"
#include "fskin/inference/trained_run.h"
#include "io/gltf_file.h"

namespace fskin::cli {
namespace {

std::string influences_text(const SkinnedCharacter& c) {
  const int64_t J = c.skeleton.num_joints();
  const int64_t kept = c.influences == 0 ? J : std::min(c.influences, J);
  return fmt::format("{} influence{}", kept, kept == 1 ? "" : "s");
}

}  // namespace

void register_export(CLI::App& app) {
  struct Options {
    std::string run, model, out, clip, data, body_model, joint_names;
    double fps = 30;
    int64_t influences = 4;
    MeshingFlags meshing;
  };
  auto opt = std::make_shared<Options>();
  opt->meshing.largest_component = true;
  auto* cmd = app.add_subcommand(
      "export", "Export a trained run's avatar, or a model .npz, as a rigged glTF character (.glb/.gltf)");
  cmd->add_option("RUN", opt->run, "run directory (fast-snarf or snarf)");
  cmd->add_option("--model", opt->model,
                  "instead of a run: an SMPL-format model .npz (template mesh, weights, skeleton; pose "
                  "correctives and shape directions are not part of a glTF skin)");
  cmd->add_option("--joint-names", opt->joint_names,
                  "text file with one joint name per line, replacing the skeleton's names in the file");
  cmd->add_option("--out", opt->out, "output .glb or .gltf")->required();
  cmd->add_option("--clip", opt->clip, "pose file .npz to include as the animation");
  cmd->add_option("--fps", opt->fps, "frames per second of the animation")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--influences", opt->influences,
                  "weights per vertex: the largest, renormalised, in sets of four (JOINTS_n/WEIGHTS_n); engines and "
                  "three.js read 4; 0 keeps every joint (the learned skinning exactly)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--data", opt->data, "dataset directory (default: the run's)");
  cmd->add_option("--body-model", opt->body_model, "model .npz the poses refer to (default: the dataset's)");
  add_meshing_flags(*cmd, opt->meshing);
  cmd->callback([opt] {
    FSKIN_CHECK(opt->run.empty() != opt->model.empty(), "fskin export: give a run directory or --model, not {}",
                opt->run.empty() ? "neither" : "both");
    gltf::is_binary_path(opt->out);  // a wrong extension fails before any work
    std::vector<std::string> names;
    if (!opt->joint_names.empty()) {
      std::ifstream in(opt->joint_names);
      FSKIN_CHECK(in.good(), "{}: cannot read the joint names", opt->joint_names);
      for (std::string line; std::getline(in, line);)
        if (!line.empty()) names.push_back(line);
    }
    const auto rename = [&](SkinnedCharacter& character) {
      if (names.empty()) return;
      FSKIN_CHECK(static_cast<int64_t>(names.size()) == character.skeleton.num_joints(),
                  "{}: {} names for a skeleton of {} joints", opt->joint_names, names.size(),
                  character.skeleton.num_joints());
      character.skeleton.joint_names = names;
      if (character.animation.size() > 0) character.animation.joint_names = names;
      character.skeleton.validate(opt->joint_names);
    };
    if (!opt->model.empty()) {
      const auto model = BodyModel::load(opt->model);
      SkinnedCharacter character{model.rig()};
      character.fps = opt->fps;
      if (!opt->clip.empty()) {
        character.animation = PoseSet::load(opt->clip);
        character.animation.validate(opt->clip, model.num_joints(), model.data().joint_names);
        character.animation.clip_names.clear();
        character.animation.clip_starts.clear();
      }
      rename(character);
      character.influences = opt->influences;
      write_skinned_gltf(opt->out, character);
      std::printf("wrote %s: %lld vertices, %lld joints, %s per vertex, %lld poses\n", opt->out.c_str(),
                  static_cast<long long>(character.mesh.num_vertices()),
                  static_cast<long long>(character.skeleton.num_joints()), influences_text(character).c_str(),
                  static_cast<long long>(character.animation.size()));
      return;
    }
    const auto device = check_meshing_flags(opt->meshing);
    const auto run = TrainedRun::load(opt->run, opt->data, {}, device);
    torch::Tensor bones;
    if (!opt->clip.empty())
      bones = DatasetPosing::load(run.data_dir, opt->body_model).bone_transforms(PoseSet::load(opt->clip), opt->clip);
    const auto canonical = mesh_canonical(*run.model, run.skeleton, run.canonical_pose, meshing_options(opt->meshing, run.config));
    auto avatar = rigged_avatar(*run.model, run.config.method, run.skeleton, canonical.mesh, bones, opt->fps);
    rename(avatar);
    avatar.influences = opt->influences;
    write_skinned_gltf(opt->out, avatar);
    std::printf("wrote %s: %lld vertices, %lld joints, %s per vertex%s\n", opt->out.c_str(),
                static_cast<long long>(avatar.mesh.num_vertices()), static_cast<long long>(avatar.skeleton.num_joints()),
                influences_text(avatar).c_str(),
                avatar.animation.size() > 0
                    ? fmt::format(", {} poses at {} fps", avatar.animation.size(), opt->fps).c_str()
                    : "");
  });
}

}  // namespace fskin::cli
