#pragma once
// Builds a posed-scan dataset on disk from an SMPL-format model and pose sets:
// one DatasetFrame .npz per pose plus manifest.json. Poses of the training pose
// set are split into contiguous blocks train / val / test_within (generated and
// captured pose files hold whole sequences back to back, so a block keeps
// neighbouring, nearly equal frames out of training, like the papers'
// held-out sequence); every pose of the OOD set goes to test_ood.
//
// Deterministic: frame i draws its points from Rng::for_item(seed, i), so
// re-running with the same inputs gives byte-identical files. Resumable:
// frames are written atomically, so a frame file that exists is complete and
// is skipped; the manifest records the parameters, and a directory built with
// different ones is refused rather than mixed.
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/body/body_model.h"
#include "fskin/data/point_sampling.h"
#include "fskin/data/pose_set.h"

namespace fskin {

struct DatasetBuildOptions {
  std::string out_dir;
  std::string model_source, poses_source, ood_poses_source;  // recorded in the manifest
  SamplingOptions sampling;  // noise_sigma is for a 1.7 m body; scaled by the model's size (character_size.h)
  uint64_t seed = 0;
  double val_fraction = 0.1;
  double test_fraction = 0.1;
  // "default" (the model's declared canonical pose; else the papers' Da-pose
  // for SMPL skeletons; else the rest pose), "da" or "rest".
  std::string canonical_pose = "default";
  // Share of each training frame's near-surface samples drawn on the faces
  // thinner than thin_thickness x the character's size (thin_faces in
  // thin_parts.h: ears, fins, fingers, capes, tails), the rest area-uniform;
  // 0 = area-uniform everywhere. Validation and test frames are always
  // area-uniform: their points define IoU_surf.
  double thin_surface_share = 0;
  double thin_thickness = 1.0 / 32;
  bool progress = true;
  void validate() const;
};

struct DatasetBuildSummary {
  int64_t frames_written = 0, frames_skipped = 0;
  int64_t train = 0, val = 0, test_within = 0, test_ood = 0;
  // Seconds spent, summed over the frames written.
  double posing_s = 0, sampling_s = 0, inside_test_s = 0, writing_s = 0;
  std::string to_string() const;
};

// ood_poses may be empty (size() == 0): no test_ood split.
DatasetBuildSummary build_dataset(const BodyModel& model, const PoseSet& poses,
                                  const PoseSet& ood_poses, const DatasetBuildOptions& options);

// Canonical pose of the dataset as axis-angle [J, 3] for a canonical-pose
// option ("default", "da", "rest"), and the name it resolved to.
// "default" resolves to "model", "da" or "rest"; other names resolve to themselves.
std::string resolve_canonical_pose(const BodyModel& model, const std::string& name);
torch::Tensor canonical_pose(const BodyModel& model, const std::string& name);

inline const std::vector<std::string>& dataset_split_names() {
  static const std::vector<std::string> names = {"train", "val", "test_within", "test_ood"};
  return names;
}

}  // namespace fskin
