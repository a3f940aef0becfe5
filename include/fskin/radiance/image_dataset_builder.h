#pragma once
// Rendering an image dataset (layout: radiance/image_dataset.h) of the
// built-in (or any SMPL-format) character with SurfaceTexture: multi-view
// (cameras on a ring) or monocular (one camera, the subject turning about
// +Y). Splits: train (training poses x training views), novel_view (training
// poses x held-out views) and novel_pose (held-out poses x held-out views).
#include <array>
#include <cstdint>
#include <string>

#include "fskin/body/body_model.h"
#include "fskin/data/pose_set.h"

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
  // Lambert shading by a fixed distant light (world space, towards the
  // light; zero: unlit albedo): colour = albedo x (ambient + (1 - ambient)
  // max(0, n . l)) with the posed surface's interpolated vertex normals, no
  // specular, no shadows. The shade of a body part then changes as it turns
  // and bends, as in a capture under a fixed lamp.
  std::array<double, 3> light{0.0, 0.0, 0.0};
  double ambient = 0.3;
  // Light that changes from frame to frame (a flickering lamp, clouds, a
  // camera's automatic exposure and white balance): each training pose's
  // colours, lit or not, scaled per channel by factors drawn uniformly from
  // [1 - light_change, 1 + light_change] (the same for every view of the
  // pose, the novel_view images of that pose included; novel poses at 1),
  // clamped to 1. A per-frame appearance code can hold it; a colour shared by
  // every frame cannot. 0: none. Deterministic in the pose's index.
  double light_change = 0;
  // The albedo (radiance/surface_texture.h): "plain" (colours, patterns,
  // seams) or "photographic" (with grain, a gradient and print on top).
  std::string texture = "plain";
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

}  // namespace fskin
