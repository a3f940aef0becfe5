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
// Splits: train, novel_view, novel_pose (radiance/image_dataset_builder.h
// renders them). This header reads a dataset; the character is
// radiance/avatar_character.h.
#include <torch/types.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fskin/skeleton/rigged_mesh.h"
#include "fskin/data/pose_set.h"
#include "fskin/geometry/pinhole_camera.h"

namespace fskin {

// The format version manifest.json records, and the file names of image i.
constexpr int kImageDatasetFormatVersion = 1;
std::string image_file_name(int64_t index);  // image_%04d.png
std::string mask_file_name(int64_t index);   // mask_%04d.png

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
  const RiggedMesh& character() const { return character_; }
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
  RiggedMesh character_;
  std::array<double, 3> background_{1.0, 1.0, 1.0};
  std::vector<std::string> splits_;
  std::string model_source_, canonical_pose_option_ = "default";
};

// The cameras of a cameras.npz (layout above) for n images: one camera
// repeated, or one per image (n < 0: as many as the file holds); each
// validated (errors name the file and the camera).
std::vector<PinholeCamera> load_cameras(const std::string& path, int64_t n);

// The canonical -> posed bone transforms [N, J, 4, 4] float32 of a poses.npz
// (`bone_transforms`, the layout above; a split's own file or one made for
// new poses) for a character of `joints` joints; validated (floating,
// finite, rigid-looking), errors name the file.
torch::Tensor load_bone_transforms(const std::string& path, int64_t joints);

// Whether the image dataset in `dir` was imported from a capture
// (radiance/capture_import.h; its manifest records the capture): its
// canonical mesh is then a body model fitted to photographs rather than the
// subject's own surface. False for any other directory, readable or not.
bool image_dataset_mesh_is_fitted(const std::string& dir);

// The box (u0, v0, u1, v1), ends exclusive, of a mask's pixels > 0, grown by
// `grow` times its size (half on each side) and clipped to the image; the
// whole image for an empty mask.
std::array<int64_t, 4> mask_box(const torch::Tensor& mask, double grow = 0.1);

inline const std::vector<std::string>& image_split_names() {
  static const std::vector<std::string> names = {"train", "novel_view", "novel_pose"};
  return names;
}

}  // namespace fskin
