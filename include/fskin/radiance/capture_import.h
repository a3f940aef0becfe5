#pragma once
// A real capture in InstantAvatar's PeopleSnapshot layout, converted into
// fskin's image dataset (docs/image_datasets.md) with the user's SMPL-family
// model (fskin ships none):
//
//   DIR/cameras.npz   intrinsic (3, 3) or (N, 3, 3), extrinsic (4, 4) or
//                     (N, 4, 4) world -> camera (OpenCV), height, width
//   DIR/images/image_%04d.png        one per frame
//   DIR/masks/mask_%04d.npy | .png   (H, W), 1 or 255 = subject
//   DIR/poses.npz     betas (S,) (1, S) or (N, S); thetas (N, 3J) or
//                     global_orient (N, 3) + body_pose (N, 3J - 3); transl (N, 3)
//
// Each frame's bone transforms are the model posed with the frame's
// parameters and the capture's betas, relative to the model's canonical pose
// with the same betas; canonical.npz holds that shaped canonical body. The
// photographs are composited over `background` by their masks (the avatar's
// evaluation renders over one colour). Frames are picked by ranges
// "start:stop:step" (Python's slices; stop may be empty = to the end).
#include <array>
#include <cstdint>
#include <string>

#include "fskin/radiance/image_dataset_builder.h"

namespace fskin {

struct FrameRange {
  int64_t start = 0, stop = -1, step = 1;  // stop < 0: to the last frame
  // "start:stop:step", "start:stop" or "start:"; throws fskin::Error naming `what`.
  static FrameRange parse(const std::string& text, const std::string& what);
  // The frame indices among `count` frames; throws when one is out of range.
  std::vector<int64_t> frames(int64_t count, const std::string& what) const;
};

struct CaptureImportOptions {
  std::string capture_dir, model_path, out_dir;
  std::string train = "0:";       // frames of the train split
  std::string novel_pose;         // frames of the novel_pose split (empty: none)
  // Pose files aligned with a split's frames (row i: the split's i-th frame),
  // as InstantAvatar keeps its refined fits (poses/anim_nerf_train.npz ...);
  // empty: DIR/poses.npz, indexed by frame. Betas come from DIR/poses.npz.
  std::string train_poses, novel_pose_poses;
  std::array<double, 3> background{1.0, 1.0, 1.0};
  std::string canonical_pose = "default";  // dataset_builder.h
  bool progress = true;
};

// Writes the dataset (resumable like build_image_dataset: frames written
// atomically and skipped when present; another capture or options refused).
// Throws fskin::Error naming the capture's file and field that is wrong.
ImageDatasetSummary import_capture(const CaptureImportOptions& options);

}  // namespace fskin
