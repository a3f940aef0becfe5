#pragma once
// The 2D stick toy set of SNARF sec. 4.1: a stick of two bones in the plane
// z = 0, articulated at its middle, with true skinning weights given by the
// inverse distance to each bone, plus an optional separate rigid object that
// the stick can touch or cross when posed (a topology change in posed space).
// The kinematics are the 3D code path (forward_kinematics with rotations about
// z), so the frames are DatasetFrames whose points have z = 0.
//
// Canonical (rest) shape: the rectangle [0, 2L] x [-h, h] (bone 0 on [0, L],
// bone 1 on [L, 2L] along x) and, with the object, the disk of radius r at
// object_centre, rigidly attached to bone 0. Posed shape: the image of the
// canonical shape under LBS with the true weights; occupancy is computed from
// the posed outline (dense boundary polygon, nonzero winding) and the posed disk.
#include <torch/types.h>

#include <array>
#include <string>
#include <cstdint>
#include <vector>

#include "fskin/data/dataset_frame.h"
#include "fskin/data/point_sampling.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

struct StickOptions {
  double bone_length = 1.0;   // L
  double half_width = 0.1;    // h
  bool with_object = false;
  std::array<double, 2> object_centre = {1.5, 0.55};
  double object_radius = 0.2;
  int64_t outline_vertices = 600;  // resolution of the posed outline
  void validate() const;
};

// Training angles in [-60, 60] degrees; extrapolation in [-120, -60] U [60, 120].
inline constexpr double kStickTrainDegrees = 60.0;
inline constexpr double kStickExtrapolationDegrees = 120.0;

Skeleton stick_skeleton(const StickOptions& options);

// True skinning weights [N, 2] of canonical points [N, 2 or 3] (x, y used):
// w_i = (1 / d_i) / sum_k (1 / d_k) with d_i the distance to bone segment i;
// points of the rigid object: (1, 0).
torch::Tensor stick_skinning_weights(const StickOptions& options, const torch::Tensor& points);

// Bone transforms [K, 2, 4, 4] (canonical = rest -> posed) for joint angles
// [K, 2] (radians): bone 0 turns about the origin, bone 1 about the joint.
torch::Tensor stick_bone_transforms(const StickOptions& options, const torch::Tensor& angles);

// Occupancy [N] uint8 of points [N, 2 or 3] for one pose's bones [2, 4, 4].
torch::Tensor stick_occupancy(const StickOptions& options, const torch::Tensor& bones,
                              const torch::Tensor& points);
// Canonical occupancy from the definition (rectangle and disk).
torch::Tensor stick_canonical_occupancy(const StickOptions& options, const torch::Tensor& points);

// `count` angle pairs [count, 2] (radians), uniform in the training range or
// (extrapolate) with both angles uniform in [60, 120] degrees with random sign.
torch::Tensor stick_angles(int64_t count, bool extrapolate, uint64_t seed);

// One frame per angle pair: half the points uniform in the posed outline's box
// enlarged 10%, half on the posed outline plus Gaussian noise noise_sigma
// (z = 0). Deterministic given seed.
std::vector<DatasetFrame> make_stick_frames(const StickOptions& options, const torch::Tensor& angles,
                                            int64_t points_per_frame, double noise_sigma,
                                            uint64_t seed);

struct StickDatasetOptions {
  std::string out_dir;
  // Frames per split; test_ood uses the extrapolation angles.
  int64_t train = 500, val = 50, test_within = 100, test_ood = 100;
  int64_t points_per_frame = 20000;
  double noise_sigma = 0.01;
  uint64_t seed = 0;
  bool progress = true;
};

// Writes the stick set in the dataset layout of build_dataset() (frame files,
// canonical.npz, manifest.json; canonical = rest pose) so Dataset reads it.
// Deterministic: a re-run writes the same bytes. Returns the frames written.
int64_t build_stick_dataset(const StickOptions& stick, const StickDatasetOptions& options);

}  // namespace fskin
