#include "fskin/data/thin_parts.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/point_sampling.h"
#include "fskin/data/random.h"

namespace fskin {

std::string ThinParts::summary(size_t max_bones) const {
  std::string out;
  for (size_t i = 0; i < bones.size() && i < max_bones; ++i)
    out += fmt::format("{}{} ({:.0f} %)", i ? ", " : "", bones[i].name, 100 * bones[i].share);
  if (bones.size() > max_bones) out += fmt::format(" and {} more", bones.size() - max_bones);
  return out;
}

ThinParts find_thin_parts(const Mesh& mesh, const CanonicalSkeleton& skeleton, double cell,
                          const ThinPartOptions& options) {
  FSKIN_CHECK(std::isfinite(cell) && cell > 0, "thin parts: the cell size must be positive, got {}", cell);
  FSKIN_CHECK(options.samples >= 1, "thin parts: needs at least one sample");
  mesh.validate("thin parts: the canonical mesh");
  Rng rng(options.seed);
  const auto sample = sample_surface_with_faces(mesh, options.samples, rng);
  // Inward unit normals of the sampled faces (faces are counter-clockwise seen from outside).
  const auto v = mesh.vertices.to(torch::kFloat32);
  const auto f = mesh.faces.index_select(0, sample.faces);
  const auto a = v.index_select(0, f.select(1, 0)), b = v.index_select(0, f.select(1, 1)),
             c = v.index_select(0, f.select(1, 2));
  const auto normal = torch::cross(b - a, c - a, 1);
  const auto inward = -normal / normal.norm(2, 1, true).clamp_min(1e-20);
  // A ladder of depths up to one cell: thin where any rung below the cell is
  // outside again, i.e. the inward ray has crossed the part. The first rung
  // sits just inside, so a sample on a thick part is inside at every rung.
  constexpr int kRungs = 8;
  std::vector<torch::Tensor> probes;
  for (int k = 1; k <= kRungs; ++k)
    probes.push_back(sample.points + inward * static_cast<float>(cell * k / (kRungs + 0.5)));
  const InsideTest inside(mesh);
  const auto occupied = inside.contains(torch::cat(probes)).view({kRungs, -1});
  const auto thin = (occupied == 0).any(0);

  ThinParts out;
  out.cell = cell;
  out.thin_fraction = thin.to(torch::kFloat64).mean().item<double>();
  const auto bone = nearest_bone(skeleton, sample.points);
  const int64_t J = static_cast<int64_t>(skeleton.parents.size());
  const auto total = torch::bincount(bone, {}, J), thin_count = torch::bincount(bone.index({thin}), {}, J);
  for (int64_t j = 0; j < J; ++j) {
    const int64_t n = total[j].item<int64_t>();
    if (n < options.min_samples) continue;
    const double share = static_cast<double>(thin_count[j].item<int64_t>()) / static_cast<double>(n);
    if (share >= options.min_share)
      out.bones.push_back({j, j < static_cast<int64_t>(skeleton.joint_names.size()) ? skeleton.joint_names[j]
                                                                                     : fmt::format("joint_{}", j),
                           share});
  }
  std::stable_sort(out.bones.begin(), out.bones.end(),
                   [](const ThinBone& x, const ThinBone& y) { return x.share > y.share; });
  return out;
}

}  // namespace fskin
