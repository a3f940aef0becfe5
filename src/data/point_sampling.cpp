#include "fskin/data/point_sampling.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

Box mesh_bounds(const Mesh& mesh, double scale) {
  FSKIN_CHECK(mesh.num_vertices() > 0, "mesh_bounds: the mesh has no vertices");
  const auto v = mesh.vertices.to(torch::kFloat64);
  const auto lo = std::get<0>(v.min(0)), hi = std::get<0>(v.max(0));
  Box box;
  for (int a = 0; a < 3; ++a) {
    const double l = lo[a].item<double>(), h = hi[a].item<double>();
    const double centre = 0.5 * (l + h), half = 0.5 * (h - l) * scale;
    box.min[a] = centre - half;
    box.max[a] = centre + half;
  }
  return box;
}

Box padded_bounds(const torch::Tensor& points, double padding) {
  FSKIN_CHECK(std::isfinite(padding) && padding >= 0, "bounds: padding must be >= 0, got {}", padding);
  expect_finite(points, "bounds: points");
  const auto p = points.reshape({-1, 3}).to(torch::kFloat64);
  FSKIN_CHECK(p.size(0) > 0, "bounds: no points");
  const auto lo = std::get<0>(p.min(0)), hi = std::get<0>(p.max(0));
  const double margin = padding * (hi - lo).max().item<double>();
  Box box;
  for (int axis = 0; axis < 3; ++axis) {
    box.min[axis] = lo[axis].item<double>() - margin;
    box.max[axis] = hi[axis].item<double>() + margin;
  }
  return box;
}

void SamplingOptions::validate() const {
  FSKIN_CHECK(uniform_points >= 0 && surface_points >= 0 && uniform_points + surface_points > 0,
              "sampling: point counts must be >= 0 and not both 0 (uniform {}, surface {})",
              uniform_points, surface_points);
  FSKIN_CHECK(box_scale >= 1.0, "sampling: box scale must be >= 1, got {}", box_scale);
  FSKIN_CHECK(noise_sigma >= 0.0 && std::isfinite(noise_sigma),
              "sampling: noise sigma must be >= 0, got {}", noise_sigma);
}

torch::Tensor sample_surface(const Mesh& mesh, int64_t count, Rng& rng) {
  return sample_surface_with_faces(mesh, count, rng).points;
}

SurfaceSamples sample_surface_with_faces(const Mesh& mesh, int64_t count, Rng& rng) {
  mesh.validate("sample_surface mesh");
  const auto v = mesh.vertices.to(torch::kFloat64).contiguous();
  const auto f = mesh.faces.contiguous();
  const double* vp = v.data_ptr<double>();
  const int64_t* fp = f.data_ptr<int64_t>();
  const int64_t F = mesh.num_faces();
  // Cumulative areas in double, summed in face order: the same on every machine.
  std::vector<double> cumulative(F);
  double total = 0.0;
  for (int64_t i = 0; i < F; ++i) {
    const double* a = vp + 3 * fp[3 * i];
    const double* b = vp + 3 * fp[3 * i + 1];
    const double* c = vp + 3 * fp[3 * i + 2];
    const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    total += 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    cumulative[i] = total;
  }
  FSKIN_CHECK(total > 0.0, "sample_surface: the mesh has zero area");
  auto out = torch::empty({count, 3}, torch::kFloat32);
  auto face_of = torch::empty({count}, torch::kInt64);
  float* op = out.data_ptr<float>();
  int64_t* fo = face_of.data_ptr<int64_t>();
  auto barycentrics = torch::empty({count, 3}, torch::kFloat64);
  double* bo = barycentrics.data_ptr<double>();
  for (int64_t k = 0; k < count; ++k) {
    const double target = rng.uniform() * total;
    const int64_t i = std::min<int64_t>(
        F - 1, std::upper_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin());
    fo[k] = i;
    // Uniform barycentric coordinates: fold the unit square onto the triangle.
    double s = rng.uniform(), t = rng.uniform();
    if (s + t > 1.0) {
      s = 1.0 - s;
      t = 1.0 - t;
    }
    const double* a = vp + 3 * fp[3 * i];
    const double* b = vp + 3 * fp[3 * i + 1];
    const double* c = vp + 3 * fp[3 * i + 2];
    for (int d = 0; d < 3; ++d)
      op[3 * k + d] = static_cast<float>(a[d] + s * (b[d] - a[d]) + t * (c[d] - a[d]));
    bo[3 * k] = 1.0 - s - t;
    bo[3 * k + 1] = s;
    bo[3 * k + 2] = t;
  }
  return {out, face_of, barycentrics};
}

torch::Tensor sample_box(const Box& box, int64_t count, Rng& rng) {
  auto out = torch::empty({count, 3}, torch::kFloat32);
  float* op = out.data_ptr<float>();
  for (int64_t k = 0; k < count; ++k)
    for (int d = 0; d < 3; ++d) op[3 * k + d] = static_cast<float>(rng.uniform(box.min[d], box.max[d]));
  return out;
}

torch::Tensor sample_frame_points(const Mesh& mesh, const SamplingOptions& options, Rng& rng) {
  return sample_frame_points(mesh, options, rng, torch::Tensor(), 0.0);
}

torch::Tensor sample_frame_points(const Mesh& mesh, const SamplingOptions& options, Rng& rng,
                                  const torch::Tensor& emphasised_faces, double share) {
  options.validate();
  FSKIN_CHECK(share >= 0 && share <= 1, "point sampling: the emphasised share must be in [0, 1], got {}", share);
  const auto uniform = sample_box(mesh_bounds(mesh, options.box_scale), options.uniform_points, rng);
  const int64_t emphasised =
      share > 0 ? static_cast<int64_t>(std::llround(share * static_cast<double>(options.surface_points))) : 0;
  auto surface = sample_surface(mesh, options.surface_points - emphasised, rng);
  if (emphasised > 0) {
    const Mesh part{mesh.vertices, mesh.faces.index_select(0, emphasised_faces), {}};
    surface = torch::cat({surface, sample_surface(part, emphasised, rng)});
  }
  float* sp = surface.data_ptr<float>();
  for (int64_t k = 0; k < surface.numel(); ++k)
    sp[k] += static_cast<float>(options.noise_sigma * rng.normal());
  return torch::cat({uniform, surface}, 0);
}

}  // namespace fskin
