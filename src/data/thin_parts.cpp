#include "fskin/data/thin_parts.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/point_sampling.h"
#include "fskin/data/random.h"

namespace fskin {
namespace {

// [N] bool: whether each point on face faces[i] of the closed mesh is on a
// part thinner than `thickness` along the face's inward normal.
torch::Tensor thinner_than(const Mesh& mesh, const torch::Tensor& points, const torch::Tensor& faces,
                           double thickness) {
  // Inward unit normals of the sampled faces (faces are counter-clockwise seen from outside).
  const auto v = mesh.vertices.to(torch::kFloat32);
  const auto f = mesh.faces.index_select(0, faces);
  const auto a = v.index_select(0, f.select(1, 0)), b = v.index_select(0, f.select(1, 1)),
             c = v.index_select(0, f.select(1, 2));
  const auto normal = torch::cross(b - a, c - a, 1);
  const auto inward = -normal / normal.norm(2, 1, true).clamp_min(1e-20);
  // A ladder of depths up to `thickness`: thin where any rung is outside
  // again, i.e. the inward ray has crossed the part. The first rung sits
  // just inside, so a sample on a thick part is inside at every rung.
  constexpr int kRungs = 8;
  std::vector<torch::Tensor> probes;
  for (int k = 1; k <= kRungs; ++k)
    probes.push_back(points + inward * static_cast<float>(thickness * k / (kRungs + 0.5)));
  const InsideTest inside(mesh);
  const auto occupied = inside.contains(torch::cat(probes)).view({kRungs, -1});
  return (occupied == 0).any(0);
}

}  // namespace

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
  const auto thin = thinner_than(mesh, sample.points, sample.faces, cell);

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

torch::Tensor thin_faces(const Mesh& mesh, double thickness) {
  FSKIN_CHECK(std::isfinite(thickness) && thickness > 0, "thin faces: the thickness must be positive, got {}",
              thickness);
  mesh.validate("thin faces: the mesh");
  const auto v = mesh.vertices.to(torch::kFloat32);
  const auto f = mesh.faces;
  const auto centroids = (v.index_select(0, f.select(1, 0)) + v.index_select(0, f.select(1, 1)) +
                          v.index_select(0, f.select(1, 2))) / 3.0f;
  const auto all = torch::arange(mesh.num_faces(), torch::kInt64);
  return all.index({thinner_than(mesh, centroids, all, thickness)});
}

}  // namespace fskin
