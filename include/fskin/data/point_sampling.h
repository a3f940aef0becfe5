#pragma once
// Query points of one frame, as in the papers (SNARF sec. 4.1): half uniform
// in the mesh's bounding box enlarged 10% (the IoU_bbox set), half near the
// surface: area-uniform surface samples plus isotropic Gaussian noise (the
// IoU_surf set). Deterministic given the Rng state.
#include <torch/types.h>

#include <array>
#include <cstdint>

#include "fskin/data/random.h"
#include "fskin/geometry/mesh.h"

namespace fskin {

struct Box {
  std::array<double, 3> min{}, max{};
};

// Axis-aligned bounds of the vertices, scaled by `scale` about their centre.
Box mesh_bounds(const Mesh& mesh, double scale = 1.0);
// Axis-aligned bounds of points [..., 3], padded on every side by `padding`
// times the longest side (throws fskin::Error on non-finite points).
Box padded_bounds(const torch::Tensor& points, double padding);

struct SamplingOptions {
  int64_t uniform_points = 100000;  // in the box
  int64_t surface_points = 100000;  // near the surface
  double box_scale = 1.1;           // box = mesh extent x this, same centre
  double noise_sigma = 0.01;        // metres; datasets scale it by body height / 1.7
  void validate() const;
};

// `count` points uniform on the surface (each face chosen with probability
// proportional to its area, then uniform barycentric coordinates). [count, 3].
torch::Tensor sample_surface(const Mesh& mesh, int64_t count, Rng& rng);
// The same samples (the same draws from rng) with the face each lies on and
// where on it.
struct SurfaceSamples {
  torch::Tensor points;        // [count, 3] float32
  torch::Tensor faces;         // [count] int64
  torch::Tensor barycentrics;  // [count, 3] float64, of the face's corners in order
};
SurfaceSamples sample_surface_with_faces(const Mesh& mesh, int64_t count, Rng& rng);
// `count` points uniform in `box`. [count, 3].
torch::Tensor sample_box(const Box& box, int64_t count, Rng& rng);
// [uniform_points + surface_points, 3] float32: the uniform part first.
torch::Tensor sample_frame_points(const Mesh& mesh, const SamplingOptions& options, Rng& rng);
// The same with `share` of the near-surface samples drawn on the faces
// `emphasised_faces` [K] int64 (area-uniform among them) and the rest
// area-uniform over the whole surface (thin parts, data/thin_parts.h). Share 0
// draws exactly what the function above draws.
torch::Tensor sample_frame_points(const Mesh& mesh, const SamplingOptions& options, Rng& rng,
                                  const torch::Tensor& emphasised_faces, double share);

}  // namespace fskin
