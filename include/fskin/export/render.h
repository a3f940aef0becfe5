#pragma once
// Offscreen software renderer for meshes: pictures for the demo, the CLI
// (`fskin render`) and reports, on machines without a display or GPU.
//
// Why by hand: a z-buffered triangle rasteriser with per-pixel shading is a few
// hundred lines, while every OpenGL route needs a context that headless CI
// machines do not have (Debian's offscreen GL stacks, OSMesa aside, want an X
// display or an EGL device), and ray tracers such as Embree are optional in
// fskin. The renderer is deterministic, so tests can check its pixels.
#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "fskin/export/image.h"
#include "fskin/geometry/mesh.h"
#include "fskin/geometry/pinhole_camera.h"

namespace fskin {

// Named camera directions (docs/conventions.md: +Y up, the body faces +Z, +X is
// the body's left). Front looks along -Z at the face, side looks along -X at
// the body's left side, back looks along +Z.
enum class View { Front, ThreeQuarter, Side, Back };

// Camera direction on a sphere around the subject: azimuth about +Y from +Z
// towards +X, elevation above the horizon (|elevation| < 90).
struct ViewAngles {
  double azimuth_degrees = 0;
  double elevation_degrees = 0;
};

ViewAngles view_angles(View view);
// "front", "three-quarter", "side", "back"; throws fskin::Error for others.
View parse_view(const std::string& name);
// `count` azimuths evenly around the subject, starting at the front.
std::vector<ViewAngles> turntable_views(int count, double elevation_degrees = 10);

struct BoundingBox {
  Eigen::Vector3f lower = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f upper = Eigen::Vector3f::Constant(-std::numeric_limits<float>::infinity());

  void extend(const Eigen::Vector3f& point);
  void extend(const BoundingBox& other);
  bool empty() const { return (lower.array() > upper.array()).any(); }
};

BoundingBox bounding_box(const Mesh& mesh);

// The camera on the ray `angles` from the centre of `box`, looking at it, at
// the smallest distance at which all eight corners project inside a
// width x height picture with `margin` (fraction of the picture size) free on
// every side; square pixels, principal point in the picture's centre.
PinholeCamera frame_camera(const BoundingBox& box, const ViewAngles& angles, int width, int height,
                           double vertical_fov_degrees, double margin);

struct RenderOptions {
  int width = 512;
  int height = 512;
  ViewAngles view = {};
  int supersampling = 3;  // s x s samples per pixel, box-filtered (anti-aliasing)
  double vertical_fov_degrees = 30;
  double margin = 0.05;
  // Frame this box instead of the mesh's own (same scale in every picture).
  std::optional<BoundingBox> framing;
  Rgb8 base_color = {200, 200, 210};  // for meshes without per-vertex colours
  Rgb8 background_top = {250, 250, 252};
  Rgb8 background_bottom = {200, 204, 214};
  // Shading: albedo * (ambient + diffuse * max(0, n.l)) + specular * max(0, n.h)^shininess,
  // with a key light above and to the left of the camera.
  double ambient = 0.3;
  double diffuse = 0.7;
  double specular = 0.12;
  double shininess = 40;
};

// Renders `mesh` (validated; throws fskin::Error naming the problem) into an
// RGB8 image of options.width x options.height.
Image render_mesh(const Mesh& mesh, const RenderOptions& options);

// One picture with a row per mesh and a column per view, each cell
// options.width x options.height. Unless options.framing is set, all cells
// frame the union of the meshes' boxes, so sizes and motion compare directly.
Image render_grid(const std::vector<Mesh>& meshes, const std::vector<ViewAngles>& views,
                  const RenderOptions& options);

// A picture and its coverage, for datasets of rendered frames (image + mask).
struct SurfaceRender {
  Image image;
  std::vector<uint8_t> mask;  // width * height, 255 * the covered fraction of each pixel
};

// Colour in [0, 1] of the surface point at barycentrics (b0, b1, b2) of face
// `face` (corners faces[face][0..2]). Called concurrently from several threads.
using SurfaceShader = std::function<Eigen::Vector3f(int64_t face, float b0, float b1, float b2)>;

// Renders `mesh` seen by `camera` (any pinhole: off-centre principal points
// and skew too) into its width x height pixels with s x s samples per pixel
// (box-filtered), each covered sample coloured by `shade` (no lighting: the
// shader's colour is the radiance), the others `background`. The same
// rasteriser as render_mesh.
SurfaceRender render_surface(const Mesh& mesh, const PinholeCamera& camera, int supersampling,
                             const SurfaceShader& shade, Rgb8 background);

}  // namespace fskin
