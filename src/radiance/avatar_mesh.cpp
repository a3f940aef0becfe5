#include "fskin/radiance/avatar_mesh.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/geometry/iso_surface.h"

namespace fskin {

Mesh avatar_mesh(Avatar& avatar, int64_t resolution, const torch::Tensor& bones) {
  FSKIN_CHECK(resolution >= 8 && resolution <= 1024, "avatar mesh: resolution must be within 8..1024, got {}",
              resolution);
  torch::NoGradGuard no_grad;
  const auto lo = avatar->canonical_lower(), hi = avatar->canonical_upper();
  const double longest = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  std::array<int64_t, 3> dims;  // D, H, W
  for (int c = 0; c < 3; ++c)
    dims[2 - c] = std::max<int64_t>(2, std::llround(static_cast<double>(resolution) * (hi[c] - lo[c]) / longest));
  const auto box = GridBox::spanning(lo, hi, dims);
  std::vector<torch::Tensor> axes;
  for (int c = 0; c < 3; ++c) axes.push_back(torch::linspace(lo[c], hi[c], dims[2 - c], torch::kFloat32));
  const auto g = torch::meshgrid({axes[2], axes[1], axes[0]}, "ij");
  const auto points = torch::stack({g[2], g[1], g[0]}, -1).reshape({-1, 3});
  const auto device = avatar->field()->table().device();
  std::vector<torch::Tensor> density;
  for (int64_t b = 0; b < points.size(0); b += 1 << 16) {
    const auto chunk = points.slice(0, b, std::min<int64_t>(b + (1 << 16), points.size(0))).to(device);
    density.push_back(avatar->field()->density(chunk).cpu());
  }
  double diagonal = 0;
  for (int c = 0; c < 3; ++c) diagonal += (hi[c] - lo[c]) * (hi[c] - lo[c]);
  const double step = std::sqrt(diagonal) / static_cast<double>(avatar->options().samples_per_diagonal);
  IsoSurfaceOptions iso;
  iso.iso = std::log(2.0) / step;  // 1 - exp(-sigma step) = 1/2
  Mesh mesh = iso_surface(torch::cat(density).reshape({dims[0], dims[1], dims[2]}), box, iso);
  FSKIN_CHECK(mesh.num_faces() > 0,
              "avatar mesh: the density nowhere reaches the surface level (sigma {:.3g} per metre); is the avatar trained?",
              iso.iso);
  mesh.colors = (avatar->field()->forward(mesh.vertices.to(device)).rgb.cpu() * 255).round().clamp(0, 255).to(torch::kUInt8);
  if (bones.defined())
    mesh.vertices = avatar->deformer().deform(mesh.vertices.unsqueeze(0), bones.to(torch::kFloat32).unsqueeze(0))[0].contiguous();
  return mesh;
}

}  // namespace fskin
