#include "fskin/gaussians/gaussian_baking.h"

#include <torch/torch.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/export/render.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/geometry/mesh_subdivision.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/gaussians/gaussian_projection.h"
#include "fskin/gaussians/spherical_harmonics.h"

namespace fskin {
namespace {

constexpr int64_t kMaxSubdivisions = 4;  // 256 faces per face: beyond it the mesh outgrows any avatar's Gaussians
constexpr int64_t kChunk = 2048;         // points per batch (bounds the [chunk, k, ...] temporaries)

}  // namespace

void GaussianBakingOptions::validate() const {
  FSKIN_CHECK(subdivisions >= -1 && subdivisions <= kMaxSubdivisions,
              "gaussian baking: subdivisions must be -1 (as many as the Gaussians ask) or 0 to {}, got {}",
              kMaxSubdivisions, subdivisions);
  FSKIN_CHECK(neighbours >= 1 && neighbours <= 1024, "gaussian baking: neighbours must be within 1..1024, got {}",
              neighbours);
}

BakedSurface bake_gaussians_at(GaussianAvatarImpl& avatar, const torch::Tensor& points, const torch::Tensor& normals,
                               const GaussianBakingOptions& options, bool blend_weights) {
  options.validate();
  expect_shape(points, {-1, 3}, "gaussian baking: points");
  expect_shape(normals, {points.size(0), 3}, "gaussian baking: normals");
  FSKIN_CHECK(avatar.size() > 0, "gaussian baking: the avatar has no Gaussians");
  torch::NoGradGuard no_grad;
  const auto f64 = torch::TensorOptions().dtype(torch::kFloat64);
  const auto means = avatar.means().detach().to(torch::kCPU, torch::kFloat64);
  // The inverse covariances R S^-2 R^T, built from the inverse scales rather
  // than inverted: discs 3 % as thick as wide are ill-conditioned to invert.
  const auto inverse_scales = torch::exp(-avatar.log_scales().detach()).to(torch::kCPU, torch::kFloat64);
  const auto precisions =
      gaussian_covariances(inverse_scales, avatar.rotations().detach().to(torch::kCPU, torch::kFloat64));
  const auto opacities = torch::sigmoid(avatar.opacity_logits().detach()).to(torch::kCPU, torch::kFloat64);
  // With appearance codes, the colours at code zero (the frames' average), as exports write them.
  const auto sh = avatar.average_appearance_sh().to(torch::kCPU, torch::kFloat64);
  const auto skinning = blend_weights ? avatar.skinning_weights().detach().to(torch::kCPU, torch::kFloat64)
                                      : torch::Tensor();
  const int64_t n = avatar.size(), k = std::min(options.neighbours, n), m = points.size(0);
  const double height = 3 * avatar.initial_spacing();

  BakedSurface out;
  out.colors = torch::zeros({m, 3}, f64);
  out.coverage = torch::zeros({m}, f64);
  if (blend_weights) out.weights = torch::zeros({m, skinning.size(1)}, f64);
  for (int64_t start = 0; start < m; start += kChunk) {
    const int64_t c = std::min(kChunk, m - start);
    const auto p = points.narrow(0, start, c).to(torch::kFloat64);
    auto normal = normals.narrow(0, start, c).to(torch::kFloat64);
    // A vertex where opposite faces meet (the rim of a zero-thickness fin) has
    // no normal: it takes its nearest Gaussian's colour.
    const auto length = normal.norm(2, 1, true);
    const auto has_normal = length > 1e-6;  // [c, 1]
    normal = normal / length.clamp_min(1e-30);
    const auto d = -normal;                   // [c, 3], the ray's direction
    const auto origin = p + height * normal;  // above the layer
    // [c, k], nearest first.
    const auto nearest = std::get<1>(torch::cdist(p, means).topk(k, 1, /*largest=*/false, /*sorted=*/true));
    const auto flat = nearest.reshape({-1});
    const auto q = means.index_select(0, flat).view({c, k, 3}) - origin.unsqueeze(1);
    const auto precision = precisions.index_select(0, flat).view({c, k, 3, 3});
    const auto dk = d.unsqueeze(1).expand({c, k, 3});
    const auto pd = torch::matmul(precision, dk.unsqueeze(-1)).squeeze(-1);  // S^-1 d
    const auto a = (dk * pd).sum(2).clamp_min(1e-30);
    const auto b = (q * pd).sum(2);
    const auto qq = (q * torch::matmul(precision, q.unsqueeze(-1)).squeeze(-1)).sum(2);
    const auto t = b / a;
    const auto power = (-0.5 * (qq - b * b / a)).clamp_max(0.0);
    auto alpha = (opacities.index_select(0, flat).view({c, k}) * torch::exp(power)).clamp_max(0.99);
    // As the rasteriser: under 1/255 a Gaussian adds nothing; only the layer below the origin counts.
    alpha = torch::where((alpha < 1.0 / 255) | (t < 0) | (t > 2 * height) | has_normal.logical_not(),
                         torch::zeros_like(alpha), alpha);
    const auto colors = spherical_harmonics_color(sh.index_select(0, flat), dk.reshape({-1, 3})).view({c, k, 3});
    // Front to back along the ray.
    const auto order = std::get<1>(t.sort(1));
    const auto alpha_sorted = alpha.gather(1, order);
    const torch::Tensor transmittance = torch::cumprod(1 - alpha_sorted, 1);
    const auto before = torch::cat({torch::ones({c, 1}, f64), transmittance.narrow(1, 0, k - 1)}, 1);
    const auto contribution = before * alpha_sorted;  // [c, k]
    const auto coverage = contribution.sum(1);
    const auto covered = (coverage > 1e-4).unsqueeze(1);
    const auto sorted_colors = colors.gather(1, order.unsqueeze(2).expand({c, k, 3}));
    const auto blended = (contribution.unsqueeze(2) * sorted_colors).sum(1) / coverage.clamp_min(1e-30).unsqueeze(1);
    out.colors.narrow(0, start, c).copy_(torch::where(covered, blended, colors.select(1, 0)));
    out.coverage.narrow(0, start, c).copy_(coverage);
    if (blend_weights) {
      const auto w = skinning.index_select(0, nearest.gather(1, order).reshape({-1})).view({c, k, -1});
      auto mixed = (contribution.unsqueeze(2) * w).sum(1) / coverage.clamp_min(1e-30).unsqueeze(1);
      mixed = torch::where(covered, mixed, skinning.index_select(0, nearest.select(1, 0)));
      out.weights.narrow(0, start, c).copy_(mixed / mixed.sum(1, true).clamp_min(1e-30));
    }
  }
  out.colors = out.colors.clamp(0, 1).to(torch::kFloat32);
  out.coverage = out.coverage.to(torch::kFloat32);
  if (blend_weights) out.weights = out.weights.to(torch::kFloat32);
  return out;
}

RiggedMesh baked_gaussian_mesh(GaussianAvatarImpl& avatar, const RiggedMesh& character,
                               const GaussianBakingOptions& options) {
  options.validate();
  character.validate("gaussian baking: character");
  const int64_t avatar_joints = avatar.skinning_weights().size(1);
  FSKIN_CHECK(character.weights.size(1) == avatar_joints, "gaussian baking: the character has {} joints, the avatar {}",
              character.weights.size(1), avatar_joints);
  RiggedMesh out;
  out.skeleton = character.skeleton;
  out.mesh = Mesh{character.mesh.vertices.to(torch::kFloat32), character.mesh.faces, {}};
  auto weights = character.weights.to(torch::kFloat32);
  int64_t levels = options.subdivisions;
  if (levels < 0) {
    // Each level multiplies the vertices by about 4.
    levels = 0;
    for (int64_t v = out.mesh.num_vertices(); v < avatar.size() && levels < kMaxSubdivisions; v *= 4) ++levels;
  }
  for (int64_t level = 0; level < levels; ++level) {
    const auto finer = subdivide_midpoints(out.mesh);
    weights = carry_to_subdivision(weights, finer.parents);
    out.mesh = finer.mesh;
  }
  const bool learned = avatar.options().learned_skinning;
  const auto baked = bake_gaussians_at(avatar, out.mesh.vertices, vertex_normals(out.mesh), options, learned);
  out.mesh.colors = (baked.colors * 255).round().to(torch::kUInt8);
  out.weights = learned ? baked.weights : weights;
  return out;
}

torch::Tensor render_baked_mesh(const RiggedMesh& baked, const torch::Tensor& bones, const PinholeCamera& camera,
                                const std::array<double, 3>& background) {
  FSKIN_CHECK(baked.mesh.colors.defined() && baked.mesh.colors.size(0) == baked.mesh.num_vertices(),
              "render_baked_mesh: the mesh has no colour per vertex");
  expect_shape(bones, {baked.weights.size(1), 4, 4}, "render_baked_mesh: bones");
  const auto colors = (baked.mesh.colors.to(torch::kFloat32) / 255).contiguous();
  const auto faces = baked.mesh.faces.contiguous();
  const float* color = colors.data_ptr<float>();
  const int64_t* corners = faces.data_ptr<int64_t>();
  const SurfaceShader shade = [&](int64_t face, float b0, float b1, float b2) {
    const float b[3] = {b0, b1, b2};
    Eigen::Vector3f c = Eigen::Vector3f::Zero();
    for (int k = 0; k < 3; ++k) c += b[k] * Eigen::Map<const Eigen::Vector3f>(color + 3 * corners[3 * face + k]);
    return c;
  };
  const auto posed = posed_vertices(baked, bones);
  Rgb8 background8;
  for (int c = 0; c < 3; ++c) {
    background8[c] = static_cast<uint8_t>(std::lround(255 * std::clamp(background[c], 0.0, 1.0)));
  }
  const auto picture = render_surface(Mesh{posed.contiguous(), faces, {}}, camera, 3, shade, background8);
  const auto& image = picture.image;
  const auto rgb8 =
      torch::from_blob(const_cast<uint8_t*>(image.rgb.data()), {image.height, image.width, 3}, torch::kUInt8);
  return rgb8.to(torch::kFloat32) / 255;  // a copy: the picture's buffer goes with it
}

int64_t write_gaussian_mesh_file(const std::string& path, GaussianAvatarImpl& avatar, const RiggedMesh& character,
                                 const GaussianExportOptions& file, const GaussianBakingOptions& options) {
  const auto extension = std::filesystem::path(path).extension().string();
  FSKIN_CHECK(extension == ".glb" || extension == ".gltf", "{}: the mesh is written as glTF: name it .glb or .gltf",
              path);
  SkinnedCharacter asset;
  static_cast<RiggedMesh&>(asset) = baked_gaussian_mesh(avatar, character, options);
  asset.fps = file.fps;
  asset.influences = file.influences;
  asset.animation_name = file.animation_name;
  if (file.bones.defined() && file.bones.numel() > 0) {
    asset.animation = animation_from_bones(asset.skeleton, file.bones);
  }
  write_skinned_gltf(path, asset);
  return asset.mesh.num_vertices();
}

}  // namespace fskin
