#pragma once
// fskin's camera: the mesh renderer's (export/render.h: frame_camera,
// render_surface), image datasets' and the radiance avatar's. A pinhole in
// OpenCV's convention (the one of PeopleSnapshot / InstantAvatar's
// cameras.npz): camera axes x right, y down, z forward; `extrinsic` maps world
// to camera; `intrinsic` K maps camera points to pixels, with the centre of
// pixel column u at x = u (so an image W wide centred on the axis has
// cx = (W - 1) / 2). docs/conventions.md, "Cameras".
#include <Eigen/Core>
#include <torch/types.h>

#include <cstdint>
#include <string>
#include <utility>

namespace fskin {

struct PinholeCamera {
  Eigen::Matrix3d intrinsic = Eigen::Matrix3d::Identity();
  Eigen::Matrix4d extrinsic = Eigen::Matrix4d::Identity();  // world -> camera
  int width = 0, height = 0;

  Eigen::Vector3d centre() const;  // the eye in world space
  // The camera's axes in world space: x (right in the picture), y (down), z (viewing direction).
  Eigen::Vector3d right() const;
  Eigen::Vector3d down() const;
  Eigen::Vector3d forward() const;
  // Camera-space coordinates of a world point (z: depth along forward()).
  Eigen::Vector3d to_camera(const Eigen::Vector3d& world) const;
  // Pixel position (u, v) of a world point (OpenCV pixel coordinates).
  Eigen::Vector2d project(const Eigen::Vector3d& world) const;

  // The same view on a picture `factor` times finer in each direction (the
  // renderers' supersampling): every point keeps its place in the picture.
  PinholeCamera supersampled(int factor) const;
  // The view of the pixels u0 <= u < u1, v0 <= v < v1 alone: the same rays,
  // the picture cut to that box (its pixel (0, 0) is this one's (u0, v0)).
  PinholeCamera cropped(int64_t u0, int64_t v0, int64_t u1, int64_t v1) const;
  // The view of the world turned by `radians` about the vertical axis (+Y,
  // docs/conventions.md) through `pivot`: a turntable's frame k is
  // orbited(2 pi k / n, subject centre).
  PinholeCamera orbited(double radians, const Eigen::Vector3d& pivot) const;
  // The view of the world turned by `radians` about the unit `axis` through
  // `pivot` (right-handed): the camera moved the other way round the pivot.
  PinholeCamera turned(const Eigen::Vector3d& axis, double radians, const Eigen::Vector3d& pivot) const;
  // Throws fskin::Error prefixed with `context` unless sizes are positive,
  // everything is finite, K is upper triangular with positive focal lengths
  // and the rotation part of `extrinsic` is orthonormal with det +1.
  void validate(const std::string& context) const;

  // K [3, 3] and world -> camera [4, 4] (OpenCV convention) from tensors of any
  // floating dtype and device, for a width x height picture; validated, errors
  // prefixed with `context`.
  static PinholeCamera from_matrices(const torch::Tensor& intrinsic, const torch::Tensor& extrinsic, int width,
                                     int height, const std::string& context);
};

// Rays through pixel positions pixels [R, 2] (u, v) -> (origins [R, 3],
// unit directions [R, 3]) in world space, float32.
std::pair<torch::Tensor, torch::Tensor> camera_rays(const PinholeCamera& camera, const torch::Tensor& pixels);
// The centres of all pixels, row by row: [H * W, 2] float32 (u, v).
torch::Tensor pixel_centres(int width, int height);

}  // namespace fskin
