#pragma once
// The poses an avatar run refined (avatar_training.h, refine_poses): per
// training frame the bones the dataset gave and the corrected ones, and, when
// the dataset keeps exact poses beside noisy ones (`bone_transforms_exact`,
// radiance/pose_perturbation.h), how far each is from the truth.
#include <torch/types.h>

#include <string>

#include "fskin/radiance/pose_correction.h"

namespace fskin {

struct RefinedPoses {
  torch::Tensor given, refined;  // [F, J, 4, 4] per training frame (frames_of_images order)
  torch::Tensor exact;           // [F, J, 4, 4], or undefined
  // Mean correction: its rotation per joint (degrees) and root shift (of the size).
  double mean_rotation_degrees = 0, mean_root_shift = 0;
  PoseError given_error, refined_error;  // against `exact`, when defined
  std::string to_string() const;
  // An .npz with given_bone_transforms, bone_transforms (refined) and, when
  // known, bone_transforms_exact.
  void save(const std::string& path) const;
};

// The poses of a volume avatar run (avatar_training.h); throws fskin::Error
// naming the run when it does not refine poses. (A Gaussian avatar run's:
// gaussians/gaussian_training.h, refined_gaussian_poses.)
RefinedPoses refined_poses(const std::string& run_dir);

// The poses of a run's learned corrections, of the character's skeleton and
// size, trained on the dataset in data_dir (whose train/poses.npz may keep the
// exact poses); run_dir names the run in errors.
RefinedPoses refined_poses(const PoseCorrectionsImpl& corrections, const Skeleton& skeleton, double size,
                           const std::string& data_dir, const std::string& run_dir);

}  // namespace fskin
