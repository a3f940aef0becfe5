#pragma once
// Image datasets of a rigged character: posed frames rendered by calibrated
// cameras, with masks and per-frame bone transforms, in the layout
// InstantAvatar reads for PeopleSnapshot (docs/image_datasets.md):
//   manifest.json           format, background, splits and their sizes
//   canonical.npz           the character: canonical vertices, faces, skinning
//                           weights, joints, joint names, parents
//   <split>/cameras.npz     intrinsic (3, 3) and extrinsic (4, 4) world->camera,
//                           height, width; (N, 3, 3) / (N, 4, 4) when each
//                           image has its own camera
//   <split>/images/image_%04d.png, <split>/masks/mask_%04d.png
//   <split>/poses.npz       bone_transforms (N, J, 4, 4) canonical -> posed,
//                           pose_index (N,), view_index (N,)
// build_image_dataset renders the built-in (or any SMPL-format) character with
// SurfaceTexture: multi-view (cameras on a ring) or monocular (one camera, the
// subject turning about +Y). Splits: train (training poses x training views),
// novel_view (training poses x held-out views) and novel_pose (held-out poses
// x held-out views).
#include <torch/types.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fskin/body/body_model.h"
#include "fskin/data/pose_set.h"
#include "fskin/radiance/pinhole_camera.h"

namespace fskin {

struct ImageDatasetOptions {
  std::string out_dir;
  int width = 256, height = 256;
  int supersampling = 3;  // s x s samples per pixel (anti-aliased edges and masks)
  int training_views = 4;  // cameras on a ring, azimuths 360 k / n from the front
  int held_out_views = 4;  // between the training ones
  // One training camera in front; the subject turns once about +Y over the
  // training frames (PeopleSnapshot's capture); held-out views as above.
  bool monocular = false;
  double elevation_degrees = 10;
  double vertical_fov_degrees = 30;
  int novel_view_frames = 8;  // training poses (evenly spread) seen from the held-out views
  std::array<double, 3> background{1.0, 1.0, 1.0};
  std::string canonical_pose = "default";  // dataset_builder.h
  std::string model_source, poses_source, ood_poses_source;  // recorded in the manifest
  bool progress = true;
  void validate() const;
};

struct ImageDatasetSummary {
  int64_t images_written = 0, images_skipped = 0;
  int64_t train = 0, novel_view = 0, novel_pose = 0;
  std::string to_string() const;
};

// Renders the dataset; resumable (images are written atomically and existing
// ones skipped; a directory built with other parameters is refused).
ImageDatasetSummary build_image_dataset(const BodyModel& model, const PoseSet& poses,
                                        const PoseSet& held_out_poses, const ImageDatasetOptions& options);

// The character of an image dataset (canonical.npz).
struct AvatarCharacter {
  torch::Tensor vertices;  // [V, 3] canonical
  torch::Tensor faces;     // [F, 3] int64
  torch::Tensor weights;   // [V, J]
  torch::Tensor joints;    // [J, 3] canonical
  std::vector<std::string> joint_names;
  std::vector<int64_t> parents;
  int64_t num_joints() const { return static_cast<int64_t>(parents.size()); }
  static AvatarCharacter load(const std::string& path);
  void save(const std::string& path) const;
};

// One split in memory.
struct ImageSplit {
  std::string name;
  std::vector<PinholeCamera> cameras;  // one per image
  torch::Tensor images;                // [N, H, W, 3] uint8
  torch::Tensor masks;                 // [N, H, W] uint8 (255 = subject)
  torch::Tensor bone_transforms;       // [N, J, 4, 4] float32, canonical -> posed
  torch::Tensor pose_index, view_index;  // [N] int64
  int64_t size() const { return images.defined() ? images.size(0) : 0; }
};

class ImageDataset {
 public:
  // Reads manifest.json and canonical.npz; throws fskin::Error naming the file.
  explicit ImageDataset(std::string dir);
  const std::string& dir() const { return dir_; }
  const AvatarCharacter& character() const { return character_; }
  std::array<double, 3> background() const { return background_; }
  std::vector<std::string> split_names() const { return splits_; }
  // Loads a split, checking that images, masks, cameras and poses agree (counts,
  // sizes, joints) and naming the file that does not.
  ImageSplit load_split(const std::string& split) const;
  // Canonical -> posed bone transforms [N, J, 4, 4] of new poses, computed as
  // build_image_dataset computed the dataset's: the body model (`model_path`,
  // or the one the manifest records) posed and made relative to the dataset's
  // canonical pose. Throws fskin::Error naming the file when the model is
  // missing or is not the dataset's (other canonical vertices), or the poses
  // do not fit its joints (errors prefixed `context`).
  torch::Tensor bone_transforms(const PoseSet& poses, const std::string& context,
                                const std::string& model_path = "") const;

 private:
  std::string dir_;
  AvatarCharacter character_;
  std::array<double, 3> background_{1.0, 1.0, 1.0};
  std::vector<std::string> splits_;
  std::string model_source_, canonical_pose_option_ = "default";
};

// The cameras of a cameras.npz (layout above) for n images: one camera
// repeated, or one per image (n < 0: as many as the file holds); each
// validated (errors name the file and the camera).
std::vector<PinholeCamera> load_cameras(const std::string& path, int64_t n);

// The box (u0, v0, u1, v1), ends exclusive, of a mask's pixels > 0, grown by
// `grow` times its size (half on each side) and clipped to the image; the
// whole image for an empty mask.
std::array<int64_t, 4> mask_box(const torch::Tensor& mask, double grow = 0.1);

inline const std::vector<std::string>& image_split_names() {
  static const std::vector<std::string> names = {"train", "novel_view", "novel_pose"};
  return names;
}

}  // namespace fskin
