// fskin pose: pose an SMPL-format model and write meshes.
#include <torch/torch.h>

#include <cstdio>
#include <filesystem>

#include "cli/commands.h"
#include "fskin/body/body_model.h"
#include "fskin/core/error.h"
#include "fskin/data/pose_set.h"
#include "fskin/io/mesh_io.h"

namespace fskin::cli {

void register_pose(CLI::App& app) {
  struct Options {
    std::string model, pose, out;
    int64_t frame = -1;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("pose", "Pose an SMPL-format model (.npz) and write meshes");
  cmd->add_option("--model", opt->model, "SMPL-format model .npz")->required();
  cmd->add_option("--pose", opt->pose, "pose file .npz with poses (N, J, 3) [and trans (N, 3)]")
      ->required();
  cmd->add_option("--out", opt->out,
                  "output mesh (.ply or .obj); with N > 1 poses, _0000.. is added before the "
                  "extension")
      ->required();
  cmd->add_option("--frame", opt->frame, "pose only this frame index");
  cmd->callback([opt] {
    const auto model = BodyModel::load(opt->model);
    const auto poses = PoseSet::load(opt->pose);
    poses.validate(opt->pose, model.num_joints(), model.data().joint_names);
    int64_t first = 0, last = poses.size();
    if (opt->frame >= 0) {
      FSKIN_CHECK(opt->frame < poses.size(), "--frame {} out of range: {} holds {} poses",
                  opt->frame, opt->pose, poses.size());
      first = opt->frame;
      last = first + 1;
    }
    const auto chosen = poses.slice(first, last);
    const auto posed = model.pose(chosen.poses, {}, chosen.trans, chosen.joint_translations);
    const std::filesystem::path out(opt->out);
    for (int64_t i = 0; i < last - first; ++i) {
      std::string path = opt->out;
      if (last - first > 1)
        path = (out.parent_path() / (out.stem().string() + fmt::format("_{:04d}", first + i) +
                                     out.extension().string()))
                   .string();
      io::write_mesh(path, Mesh{posed.vertices[i].contiguous(), model.data().faces, {}});
      std::printf("wrote %s (%lld vertices, %lld faces)\n", path.c_str(),
                  static_cast<long long>(model.num_vertices()),
                  static_cast<long long>(model.data().faces.size(0)));
    }
  });
}

}  // namespace fskin::cli
