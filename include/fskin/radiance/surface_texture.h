#pragma once
// The textured character of the image datasets: a procedural albedo on any
// rigged mesh, with detail worth learning, evaluated per rendered sample at
// the canonical position and skinning weights the sample interpolates (so its
// detail does not depend on the mesh's resolution):
//   - a colour per dominant bone (bone_palette, lightened),
//   - a pattern per bone cycling through stripes across the body's longest
//     axis, a 3D checker and dots, of period character_size / 24,
//   - dark seams where the two largest skinning weights are within 0.1
//     (the boundaries between body parts, like clothing seams),
//   - for skeletons with SMPL's joint names only (the built-in character,
//     SMPL fits; +Z is the face's forward there): skin on the head and hands,
//     dark shoes, and a face (eyes and a mouth) placed from the head bone's
//     own vertices.
// With `photographic` detail (ImageDatasetOptions::texture "photographic"),
// on top of all that, what a photograph of printed cloth holds and flat
// colours do not:
//   - grain: value noise of three octaves (periods period / 2, / 5, / 12)
//     scaling the brightness by up to about +-20 %,
//   - a gradient: the brightness rising from 0.8 to 1.15 x along the body's
//     longest axis, and a warm tint towards its top,
//   - print: lines of small glyphs (a 3 x 5 pixel font, letters and digits,
//     a glyph pixel period / 4 wide) on the parts without a face, hands or
//     shoes, every fourth line of glyph cells along the longest axis.
// Colours are albedo in [0, 1]; the image datasets render them unlit, so the
// radiance is the same from every view.
#include <Eigen/Core>
#include <torch/types.h>

#include <string>
#include <vector>

namespace fskin {

class SurfaceTexture {
 public:
  // canonical_vertices [V, 3], weights [V, J] (rows >= 0 summing to 1),
  // joint_names J names (for the SMPL-only features; any names work).
  SurfaceTexture(const torch::Tensor& canonical_vertices, const torch::Tensor& weights,
                 const std::vector<std::string>& joint_names, bool photographic = false);

  int64_t num_bones() const { return static_cast<int64_t>(palette_.size()); }
  // Albedo at canonical point p with skinning weights w[0..J).
  Eigen::Vector3f albedo(const Eigen::Vector3f& p, const float* w) const;
  // Albedo of every vertex [V, 3] uint8 (for coloured meshes of the character).
  torch::Tensor vertex_colors(const torch::Tensor& canonical_vertices, const torch::Tensor& weights) const;

 private:
  enum class Part { Plain, Skin, Shoe, Head };
  Eigen::Vector3f base_albedo(const Eigen::Vector3f& p, const float* w, bool* printable) const;
  std::vector<Eigen::Vector3f> palette_;
  std::vector<Part> parts_;
  double period_ = 0.1;
  int long_axis_ = 1;
  int print_axis_ = 0;  // the glyphs' rows run along it: the second-longest axis
  bool photographic_ = false;
  float long_low_ = 0, long_extent_ = 1;
  // The face (SMPL-named skeletons): centre, half extents of the head bone's vertices.
  bool has_face_ = false;
  Eigen::Vector3f head_centre_ = Eigen::Vector3f::Zero(), head_half_ = Eigen::Vector3f::Ones();
};

}  // namespace fskin
