#pragma once
// The meshing flags `fskin mesh` and `fskin animate` share.
#include <CLI/CLI.hpp>

#include <cctype>
#include <filesystem>
#include <string>

#include "fskin/core/device.h"
#include "fskin/core/error.h"

#include "fskin/inference/posed_meshing.h"
#include "fskin/training/train_config.h"

namespace fskin::cli {

struct MeshingFlags {
  int64_t resolution = 256, initial = 32, batch = 0;
  int64_t surface_steps = PosedMeshingOptions{}.surface_steps;
  double padding = 0.1;
  bool largest_component = false;
  std::string device = "cpu";  // where the model runs (core/device.h); meshes come back to the host
};

inline void add_meshing_flags(CLI::App& cmd, MeshingFlags& flags) {
  cmd.add_option("--resolution", flags.resolution, "final grid cells along the box's longest side")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd.add_option("--initial", flags.initial, "MISE's coarse grid cells along that side (resolution / 2^k)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd.add_option("--batch", flags.batch, "points per model call (default: the run's eval_chunk_points)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--padding", flags.padding, "box margin per side, as a fraction of its longest side")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd.add_option("--surface-steps", flags.surface_steps,
                 "model evaluations per vertex that move it onto the surface (0: marching cubes' linear "
                 "interpolation, which leaves terraces on learned occupancies)")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  cmd.add_flag("--largest-component", flags.largest_component, "keep only the connected component with most faces");
  cmd.add_option("--device", flags.device, "cpu, cuda or cuda:N: where the model runs")->capture_default_str();
}

// Checks the flags before any work: fails unless resolution / initial is a power of two.
// Returns the device the model runs on.
inline torch::Device check_meshing_flags(const MeshingFlags& flags) {
  MiseOptions::resolutions(flags.initial, flags.resolution);
  return parse_device(flags.device);
}

// Fails before any work when `path` is not a mesh file name fskin writes.
inline void check_mesh_path(const std::string& path) {
  auto ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  FSKIN_CHECK(ext == ".ply" || ext == ".obj", "{}: the output must end in .ply or .obj", path);
}

inline PosedMeshingOptions meshing_options(const MeshingFlags& flags, const TrainConfig& config) {
  PosedMeshingOptions options;
  options.mise = MiseOptions::resolutions(flags.initial, flags.resolution);
  options.mise.batch_size = flags.batch > 0 ? flags.batch : config.eval_chunk_points;
  options.surface_steps = flags.surface_steps;
  options.padding = flags.padding;
  options.largest_component = flags.largest_component;
  return options;
}

}  // namespace fskin::cli
