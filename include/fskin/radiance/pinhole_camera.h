#pragma once
// Pinhole cameras of image datasets, in OpenCV's convention (the one of
// PeopleSnapshot / InstantAvatar's cameras.npz): camera axes x right, y down,
// z forward; `extrinsic` maps world to camera; `intrinsic` K maps camera
// points to pixels, with the centre of pixel column u at x = u (so an image
// W wide centred on the axis has cx = (W - 1) / 2). docs/conventions.md, "Cameras".
#include <Eigen/Core>
#include <torch/types.h>

#include <string>
#include <utility>

#include "fskin/export/render.h"

namespace fskin {

struct PinholeCamera {
  Eigen::Matrix3d intrinsic = Eigen::Matrix3d::Identity();
  Eigen::Matrix4d extrinsic = Eigen::Matrix4d::Identity();  // world -> camera
  int width = 0, height = 0;

  // The renderer's camera (export/render.h) as a pinhole camera: both project
  // every point to the same pixel position.
  static PinholeCamera from_render_camera(const Camera& camera, int width, int height);
  // Back to the renderer's camera; throws unless K has square pixels, no skew
  // and its principal point in the centre (what the renderer draws).
  Camera to_render_camera() const;

  Eigen::Vector3d centre() const;  // the eye in world space
  // Pixel position (u, v) of a world point (OpenCV pixel coordinates).
  Eigen::Vector2d project(const Eigen::Vector3d& world) const;
  // Throws fskin::Error prefixed with `context` unless sizes are positive,
  // everything is finite, K is upper triangular with positive focal lengths
  // and the rotation part of `extrinsic` is orthonormal with det +1.
  void validate(const std::string& context) const;
};

// Rays through pixel positions pixels [R, 2] (u, v) -> (origins [R, 3],
// unit directions [R, 3]) in world space, float32.
std::pair<torch::Tensor, torch::Tensor> camera_rays(const PinholeCamera& camera, const torch::Tensor& pixels);
// The centres of all pixels, row by row: [H * W, 2] float32 (u, v).
torch::Tensor pixel_centres(int width, int height);

}  // namespace fskin
