#pragma once
// A trained run animated by a pose sequence into a directory, as
// `fskin animate RUN --poses` and Python's `Run.animate` write it:
//   re-posing (INS eq. 19): the canonical mesh once (MISE), coloured by
//     arg-max skinning bone, its vertices moved into every pose:
//     DIR/canonical.ply, DIR/frame_0000.ply ..., DIR/animation.glb (one mesh,
//     a morph target per frame);
//   per pose: one MISE mesh in every pose (SNARF / Fast-SNARF's per-frame
//     cost): DIR/frame_0000.ply ...;
// and DIR/meshing.json, the timings and sample counts.
#include <nlohmann/json.hpp>
#include <torch/types.h>

#include <string>

#include "fskin/inference/posed_meshing.h"
#include "fskin/inference/trained_run.h"

namespace fskin {

enum class RunAnimationMode {
  Default,  // re-posing for INS runs (their canonical shape is pose-free), per pose for the others
  Repose,
  PerPose,
};

struct RunAnimationOptions {
  RunAnimationMode mode = RunAnimationMode::Default;
  PosedMeshingOptions meshing;
  double fps = 30;                // animation.glb's frame rate (re-posing)
  int64_t repose_batch = 8;       // poses re-posed per model call
  bool progress = true;
};

struct RunAnimationResult {
  RunAnimationMode mode = RunAnimationMode::Repose;  // the one used (never Default)
  nlohmann::json summary;                            // what DIR/meshing.json holds
  // Two lines for a terminal: what was written and how fast.
  std::string description;
};

// Animates `run` in the poses `poses` [N, J, 3] with their bone transforms
// `bones` [N, J, 4, 4] (canonical -> posed, as the run's dataset poses:
// DatasetPosing); `label` names the poses in meshing.json (a file name).
// Creates `out` (throws fskin::Error naming it when that fails).
RunAnimationResult animate_run(TrainedRun& run, const torch::Tensor& poses, const torch::Tensor& bones,
                               const std::string& label, const std::string& out, const RunAnimationOptions& options);

}  // namespace fskin
