// fskin mesh: the surface of a trained run in a pose (or canonical), by MISE + marching cubes.
#include <fmt/format.h>

#include <cstdio>

#include "cli/commands.h"
#include "cli/meshing_options.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/io/mesh_io.h"
#include "fskin/inference/posed_meshing.h"
#include "fskin/inference/trained_run.h"
#include "fskin/util/progress.h"

namespace fskin::cli {

void register_mesh(CLI::App& app) {
  struct Options {
    std::string run, pose, out, data, model, checkpoint = "latest";
    int64_t index = 0;
    bool canonical = false, quiet = false;
    MeshingFlags meshing;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand(
      "mesh", "Extract the surface of a trained run in a pose (MISE + marching cubes) as .ply or .obj");
  cmd->add_option("run", opt->run, "run directory written by fskin train")->required();
  auto* pose = cmd->add_option("--pose", opt->pose, "pose file .npz (N, J, 3)");
  cmd->add_option("--index", opt->index, "which pose of the file (default 0)")->needs(pose);
  cmd->add_flag("--canonical", opt->canonical, "mesh the canonical shape (conditioned on the canonical pose)")
      ->excludes(pose);
  cmd->add_option("--out", opt->out, "output mesh .ply or .obj")->required();
  add_meshing_flags(*cmd, opt->meshing);
  cmd->add_option("--data", opt->data, "dataset directory (default: the one the run trained on)");
  cmd->add_option("--model", opt->model,
                  "with --pose: body model .npz the dataset was built from (default: the manifest's)");
  cmd->add_option("--checkpoint", opt->checkpoint,
                  "which checkpoint: latest (default), best (on the val split, needs validate_every) or a step");
  cmd->add_flag("--quiet", opt->quiet, "no progress bar");
  cmd->callback([opt] {
    FSKIN_CHECK(opt->canonical || !opt->pose.empty(), "mesh: give --pose FILE (and --index K) or --canonical");
    // The pose file first: a wrong file fails before the run is loaded.
    check_mesh_path(opt->out);
    const auto device = check_meshing_flags(opt->meshing);
    PoseSet pose;
    if (!opt->canonical) {
      const auto poses = PoseSet::load(opt->pose);
      FSKIN_CHECK(opt->index >= 0 && opt->index < poses.size(), "{}: pose index {} out of range [0, {})", opt->pose,
                  opt->index, poses.size());
      const int64_t k = opt->index;
      pose = poses.slice(k, k + 1);
    }
    auto run = TrainedRun::load(opt->run, opt->data, CheckpointChoice::parse(opt->checkpoint), device);
    const auto options = meshing_options(opt->meshing, run.config);
    ProgressBar bar("meshing", options.mise.upsampling_steps + 1, !opt->quiet);
    const MiseProgress progress = [&](int64_t level, int64_t, int64_t points) {
      bar.advance(1, fmt::format("level {}, {} points evaluated", level, points));
    };
    MeshingResult result;
    if (opt->canonical) {
      result = mesh_canonical(*run.model, run.skeleton, run.canonical_pose, options, progress);
    } else {
      const auto posing = DatasetPosing::load(run.data_dir, opt->model);
      const auto bones = posing.bone_transforms(pose, opt->pose);
      result = mesh_posed(*run.model, run.skeleton, bones[0], pose.poses[0], options, progress);
    }
    bar.finish();
    if (result.mesh.num_faces() == 0)
      std::fprintf(stderr, "fskin: warning: no surface found (is the run trained?); writing an empty mesh\n");
    io::write_mesh(opt->out, result.mesh);
    std::printf("wrote %s: %lld vertices, %lld faces (%s, step %lld)\n%s\n", opt->out.c_str(),
                static_cast<long long>(result.mesh.num_vertices()), static_cast<long long>(result.mesh.num_faces()),
                run.config.method.c_str(), static_cast<long long>(run.step),
                result.stats.summary().c_str());
  });
}

}  // namespace fskin::cli
