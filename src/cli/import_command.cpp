// fskin import: a rigged character (glTF 2.0, FBX, Collada, ...) as an
// SMPL-format model .npz (and its animation clips as one pose file).
#include <cstdio>

#include "cli/commands.h"
#include "fskin/import/imported_character.h"
#include "fskin/core/error.h"

namespace fskin::cli {

void register_import(CLI::App& app) {
  struct Options {
    std::string input, out, clips;
    ImportOptions import;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand(
      "import", "Import a rigged character (glTF 2.0, FBX, Collada, ...): skinned mesh, skeleton and animation clips");
  cmd->add_option("CHARACTER", opt->input, "rigged character file: .glb/.gltf, .fbx, .dae or another format assimp reads")->required();
  cmd->add_option("--out", opt->out, "output model .npz")->required();
  cmd->add_option("--clips", opt->clips,
                  "also write every animation clip, back to back with its name, as one pose file .npz");
  cmd->add_flag("--keep-open-parts", opt->import.keep_open_parts,
                "keep mesh parts that are not closed surfaces (training needs closed ones)");
  cmd->add_option("--assimp-seconds", opt->import.assimp_seconds,
                  "FBX, Collada and other assimp formats: the time assimp may take to read the file (in a child "
                  "process, before fskin reads it)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--assimp-memory-mib", opt->import.assimp_memory_mib,
                  "... and the memory it may take, in MiB")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->callback([opt] {
    const auto imported = import_character(opt->input, opt->import);
    const BodyModel model(imported.model, opt->input);
    model.save(opt->out);
    std::printf("wrote %s: %lld vertices, %lld faces, %lld joints (root '%s')\n", opt->out.c_str(),
                static_cast<long long>(model.num_vertices()), static_cast<long long>(model.data().faces.size(0)),
                static_cast<long long>(model.num_joints()), model.data().joint_names.front().c_str());
    for (const auto& note : imported.notes) std::printf("  %s\n", note.c_str());
    for (const auto& clip : imported.clips)
      std::printf("  clip '%s': %lld frames at %.4g fps\n", clip.name.c_str(), static_cast<long long>(clip.poses.size()),
                  clip.fps);
    if (!opt->clips.empty()) {
      FSKIN_CHECK(!imported.clips.empty(), "{}: --clips given but the file has no animation", opt->input);
      concatenate_clips(imported.clips).save(opt->clips);
      std::printf("wrote %s (%zu clips)\n", opt->clips.c_str(), imported.clips.size());
    }
  });
}

}  // namespace fskin::cli
