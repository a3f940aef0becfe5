#pragma once
// A copy of an image dataset whose poses carry the noise of a fitted capture:
// every training pose gets a rotation of `degrees` about a random axis at each
// joint and a root shift of `translation` x the character's size in a random
// direction (radiance/pose_correction.h applies them down the tree), then the
// mean of each over the poses is subtracted (an unbiased pose source; each
// pose's noise is then about, not exactly, `degrees`). The
// images stay as rendered, so the recorded poses no longer explain them, as
// with a pose estimator's fits; pose refinement (avatar_training.h) is
// measured on such a copy against the exact poses, which each perturbed
// poses.npz keeps as `bone_transforms_exact`.
//
// The train and novel_view splits are perturbed (a pose seen by several views
// gets one noise); novel_pose keeps its exact poses: the held-out poses
// measure the avatar, not the poses.
#include <cstdint>
#include <string>

namespace fskin {

struct PosePerturbationOptions {
  std::string data_dir, out_dir;
  double degrees = 5;         // rotation per joint
  double translation = 0.01;  // root shift, in units of the character's size
  uint64_t seed = 0;
  void validate() const;
};

struct PosePerturbationSummary {
  int64_t frames = 0;                          // distinct perturbed poses
  double rotation_degrees = 0, joint_distance = 0;  // pose_error of the result against the exact poses
  std::string to_string() const;
};

PosePerturbationSummary perturb_image_dataset_poses(const PosePerturbationOptions& options);

}  // namespace fskin
