#include "fskin/gaussians/gaussian_avatar.h"

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/point_sampling.h"
#include "fskin/data/random.h"
#include "fskin/fields/preset_skinning_field.h"
#include "fskin/geometry/character_size.h"
#include "fskin/gaussians/gaussian_projection.h"
#include "fskin/gaussians/spherical_harmonics.h"
#include "fskin/ops/gaussian_rasterization.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {
namespace {

// The character's vertex weights where the samples lie on its faces,
// interpolated with their barycentric coordinates [M, J] float32.
torch::Tensor surface_point_weights(const RiggedMesh& character, const SurfaceSamples& samples) {
  const auto corners = character.mesh.faces.index_select(0, samples.faces);  // [M, 3]
  const auto w = character.weights.to(torch::kFloat64);
  auto blended = torch::zeros({samples.faces.size(0), w.size(1)}, torch::kFloat64);
  for (int k = 0; k < 3; ++k) {
    blended += samples.barycentrics.select(1, k).unsqueeze(1) * w.index_select(0, corners.select(1, k));
  }
  return blended.to(torch::kFloat32);
}

}  // namespace

void GaussianAvatarOptions::validate() const {
  FSKIN_CHECK(initial_gaussians >= 1 && initial_gaussians <= 10'000'000,
              "gaussian avatar: initial_gaussians must be within 1..10000000, got {}", initial_gaussians);
  FSKIN_CHECK(sh_degree >= 0 && sh_degree <= 3, "gaussian avatar: sh_degree must be 0 to 3, got {}", sh_degree);
  FSKIN_CHECK(initial_thickness > 0 && initial_thickness <= 1,
              "gaussian avatar: initial_thickness must be within (0, 1], got {}", initial_thickness);
  FSKIN_CHECK(initial_opacity > 0 && initial_opacity < 1,
              "gaussian avatar: initial_opacity must be within (0, 1), got {}", initial_opacity);
  FSKIN_CHECK(skinning_source == "surface" || skinning_source == "grid",
              "gaussian avatar: the skinning source must be \"surface\" or \"grid\", got \"{}\"", skinning_source);
  FSKIN_CHECK(skinning_grid_resolution >= 4 && skinning_grid_resolution <= 512,
              "gaussian avatar: skinning grid resolution must be within 4..512, got {}", skinning_grid_resolution);
  FSKIN_CHECK(dilation >= 0 && dilation <= 10, "gaussian avatar: dilation must be within 0..10 pixels^2, got {}",
              dilation);
  FSKIN_CHECK(shading == "none" || shading == "irradiance",
              "gaussian avatar: shading must be \"none\" or \"irradiance\", got \"{}\"", shading);
  appearance.validate();
}

GaussianAvatarImpl::GaussianAvatarImpl(const RiggedMesh& character, GaussianAvatarOptions options, uint64_t seed)
    : options_(std::move(options)) {
  options_.validate();
  character.validate("gaussian avatar: character");
  const auto vertices = character.mesh.vertices.to(torch::kFloat32);
  bones_ = character.weights.size(1);
  const bool from_grid = options_.skinning_source == "grid";
  if (from_grid) {
    skinning_ = diffuse_weights_to_grid(
        vertices, character.weights.to(torch::kFloat32),
        VoxelBox::fit(vertices.to(torch::kFloat64), options_.skinning_grid_resolution));
  }
  Rng rng(seed);
  const int64_t n = options_.initial_gaussians;
  const auto samples = sample_surface_with_faces(character.mesh, n, rng);
  const auto points = samples.points.to(torch::kFloat32);
  surface_weights_ = register_buffer(
      "surface_weights", from_grid ? torch::zeros({n, 0})
                                   : surface_point_weights(character, samples));
  skinning_corrections_ =
      register_parameter("skinning_corrections", torch::zeros({n, options_.learned_skinning ? bones_ : 0}));
  // Faces' total area over N: each sample's share of the surface, whose square root is their spacing.
  const auto v = character.mesh.vertices.to(torch::kFloat64);
  const auto f = character.mesh.faces;
  const auto e1 = v.index_select(0, f.select(1, 1)) - v.index_select(0, f.select(1, 0));
  const auto e2 = v.index_select(0, f.select(1, 2)) - v.index_select(0, f.select(1, 0));
  const double area = 0.5 * torch::cross(e1, e2, 1).norm(2, 1).sum().item<double>();
  const double spacing = std::sqrt(std::max(area, 1e-12) / static_cast<double>(n));
  initial_spacing_ = spacing;
  means_ = register_parameter("means", points);
  auto log_scales = torch::full({n, 3}, static_cast<float>(std::log(spacing)));
  auto rotations = torch::tensor({1.0f, 0.0f, 0.0f, 0.0f}).repeat({n, 1});
  const auto corners = f.index_select(0, samples.faces);
  const auto corner_a = v.index_select(0, corners.select(1, 0));
  const auto face_normal = torch::cross(v.index_select(0, corners.select(1, 1)) - corner_a,
                                        v.index_select(0, corners.select(1, 2)) - corner_a, 1);
  const auto unit_normal = face_normal / face_normal.norm(2, 1, true).clamp_min(1e-30);
  surface_anchors_ = torch::zeros({n, 0});
  if (options_.anchored) {
    surface_anchors_ = register_buffer("surface_anchors", torch::cat({points.detach(), unit_normal.to(torch::kFloat32)}, 1));
  }
  if (options_.initial_thickness < 1 || options_.shading != "none") {
    // Discs in the faces' planes: the local z axis along the face normal
    // (outward where faces wind counter-clockwise seen from outside, glTF's
    // convention), that scale thinner; shading reads the z axis as the normal.
    log_scales.select(1, 2).add_(static_cast<float>(std::log(options_.initial_thickness)));
    const auto& z = unit_normal;
    // Any x perpendicular to z: the world axis least aligned with it, made orthogonal.
    const auto least = z.abs().argmin(1);
    auto x = torch::zeros_like(z).scatter_(1, least.unsqueeze(1), 1.0);
    x = x - (x * z).sum(1, true) * z;
    x = x / x.norm(2, 1, true);
    const auto y = torch::cross(z, x, 1);
    rotations = matrix_to_quaternion(torch::stack({x, y, z}, 2)).to(torch::kFloat32);
  }
  if (options_.non_rigid) {
    non_rigid_ = register_module(
        "non_rigid", NonRigidOffset(bones_, std::get<0>(v.min(0)), std::get<0>(v.max(0)),
                                    character_size(v, "gaussian avatar: canonical vertices"), options_.non_rigid_network));
  }
  if (options_.shading == "irradiance") shading_ = register_module("shading", GaussianShading());
  if (options_.appearance.dim > 0) {
    appearance_ = register_module(
        "appearance", GaussianAppearance(std::get<0>(v.min(0)), std::get<0>(v.max(0)), options_.appearance));
  }
  log_scales_ = register_parameter("log_scales", log_scales);
  rotations_ = register_parameter("rotations", rotations);
  const double logit = std::log(options_.initial_opacity / (1 - options_.initial_opacity));
  opacity_logits_ = register_parameter("opacity_logits", torch::full({n}, static_cast<float>(logit)));
  sh_dc_ = register_parameter("sh_dc", torch::zeros({n, 1, 3}));
  sh_rest_ = register_parameter("sh_rest",
                                torch::zeros({n, spherical_harmonics_coefficients(options_.sh_degree) - 1, 3}));
}

torch::Tensor GaussianAvatarImpl::sh() const { return torch::cat({sh_dc_, sh_rest_}, 1); }

torch::Tensor GaussianAvatarImpl::average_appearance_sh() {
  torch::NoGradGuard no_grad;
  auto dc = sh_dc_.detach();
  // The colour's offset d is the degree-0 coefficient's d / Y_0 (spherical_harmonics.h).
  if (appearance_) dc = dc + color_to_spherical_harmonics_dc(appearance_->forward(means_, {}) + 0.5).unsqueeze(1);
  return torch::cat({dc, sh_rest_.detach()}, 1);
}

torch::Tensor GaussianAvatarImpl::skinning_weights() {
  const auto source = skinning_ ? skinning_->weights(means_) : surface_weights_;
  if (!options_.learned_skinning) return source;
  // Floored so that a bone without weight stays reachable by its logit.
  return torch::softmax(torch::log(source.clamp_min(1e-6)) + skinning_corrections_, 1);
}

PosedGaussians GaussianAvatarImpl::pose(const torch::Tensor& bones) {
  expect_shape(bones, {bones_, 4, 4}, "gaussian avatar: bone transforms");
  const auto transforms = blend_transforms(skinning_weights(), bones.to(means_.options()).unsqueeze(0))[0];
  PosedGaussians posed;
  posed.linear = transforms.narrow(1, 0, 3).narrow(2, 0, 3);
  if (non_rigid_) posed.offsets = non_rigid_->forward(means_, bones);
  posed.means = transform_points(transforms, posed.offsets.defined() ? means_ + posed.offsets : means_);
  const auto canonical = gaussian_covariances(torch::exp(log_scales_), rotations_);
  posed.covariances = torch::matmul(torch::matmul(posed.linear, canonical), posed.linear.transpose(1, 2));
  posed.opacities = torch::sigmoid(opacity_logits_);
  return posed;
}

Eigen::Vector3d posed_centre(const torch::Tensor& means) {
  const auto m = means.detach();
  const auto middle =
      (0.5 * (std::get<0>(m.min(0)) + std::get<0>(m.max(0)))).to(torch::kCPU, torch::kFloat64).contiguous();
  const double* c = middle.data_ptr<double>();
  return {c[0], c[1], c[2]};
}

Eigen::Vector3d GaussianAvatarImpl::centre(const torch::Tensor& bones) {
  torch::NoGradGuard no_grad;
  return posed_centre(pose(bones.detach().to(torch::kFloat32)).means);
}

GaussianRender GaussianAvatarImpl::render(const torch::Tensor& bones, const PinholeCamera& camera,
                                          const std::array<double, 3>& background, const torch::Tensor& appearance) {
  return render(pose(bones), camera, background, appearance);
}

GaussianRender GaussianAvatarImpl::render(const PosedGaussians& posed, const PinholeCamera& camera,
                                          const std::array<double, 3>& background, const torch::Tensor& appearance) {
  FSKIN_CHECK(!appearance.defined() || appearance_,
              "gaussian avatar: an appearance code given to an avatar without appearance codes");
  ProjectionOptions projection;
  projection.compensate = options_.antialiased;
  projection.dilation = options_.dilation;
  const auto projected = project_gaussians(posed.means, posed.covariances, camera, projection);
  // View directions in canonical space: A^T (mean' - eye), normalised.
  const Eigen::Vector3d eye = camera.centre();
  const auto eye_tensor = torch::tensor({eye.x(), eye.y(), eye.z()}, torch::kFloat64).to(means_.options());
  const auto view = torch::matmul(posed.linear.transpose(1, 2), (posed.means - eye_tensor).unsqueeze(-1)).squeeze(-1);
  const auto directions = view / view.norm(2, 1, true).clamp_min(1e-12);
  auto colors = spherical_harmonics_color(sh(), directions);
  if (appearance_) colors = (colors + appearance_->forward(means_, appearance)).clamp_min(0);
  if (shading_) {
    // The normals without gradients: through them each Gaussian could tilt
    // to set its own shade, which fits the training views and draws the
    // tilted footprints in others (gaussian_shading.h).
    colors = colors * shading_->forward(posed_gaussian_normals(rotations_.detach(), posed.linear.detach()));
  }
  const auto bg = torch::tensor({background[0], background[1], background[2]}, means_.options());
  const auto opacities =
      options_.antialiased ? posed.opacities * projected.opacity_compensation : posed.opacities;
  GaussianRender out;
  std::tie(out.image, out.alpha) =
      rasterize_gaussians(projected.means2d, projected.conics, colors, opacities, projected.depths,
                          projected.radii, bg, camera.width, camera.height);
  out.means2d = projected.means2d;
  out.radii = projected.radii;
  out.offsets = posed.offsets;
  return out;
}

torch::Tensor GaussianAvatarImpl::anchor_heights() const {
  FSKIN_CHECK(options_.anchored, "gaussian avatar: anchor heights asked of an avatar without anchors");
  const auto point = surface_anchors_.narrow(1, 0, 3), normal = surface_anchors_.narrow(1, 3, 3);
  return ((means_ - point) * normal).sum(1);
}

void GaussianAvatarImpl::load(torch::serialize::InputArchive& archive) {
  torch::nn::Module::load(archive);
  if (!options_.anchored) surface_anchors_ = torch::zeros({size(), 0});
}

void GaussianAvatarImpl::replace_gaussians(torch::Tensor means, torch::Tensor log_scales, torch::Tensor rotations,
                                           torch::Tensor opacity_logits, torch::Tensor sh_dc,
                                           torch::Tensor sh_rest, torch::Tensor surface_weights,
                                           torch::Tensor skinning_corrections, torch::Tensor surface_anchors) {
  const int64_t n = means.size(0);
  expect_shape(means, {n, 3}, "gaussian avatar: means");
  expect_shape(log_scales, {n, 3}, "gaussian avatar: log_scales");
  expect_shape(rotations, {n, 4}, "gaussian avatar: rotations");
  expect_shape(opacity_logits, {n}, "gaussian avatar: opacity_logits");
  expect_shape(sh_dc, {n, 1, 3}, "gaussian avatar: sh_dc");
  expect_shape(sh_rest, {n, sh_rest_.size(1), 3}, "gaussian avatar: sh_rest");
  expect_shape(surface_weights, {n, surface_weights_.size(1)}, "gaussian avatar: surface_weights");
  expect_shape(skinning_corrections, {n, skinning_corrections_.size(1)}, "gaussian avatar: skinning_corrections");
  expect_shape(surface_anchors, {n, surface_anchors_.size(1)}, "gaussian avatar: surface_anchors");
  // set_data keeps each parameter's identity (the module's registry and the
  // optimiser's parameter lists still hold it) while its size changes; the
  // optimiser's per-parameter state is the caller's to resize. Gradients of
  // the old size are dropped.
  torch::NoGradGuard no_grad;
  means_.set_data(means.detach().clone());
  log_scales_.set_data(log_scales.detach().clone());
  rotations_.set_data(rotations.detach().clone());
  opacity_logits_.set_data(opacity_logits.detach().clone());
  sh_dc_.set_data(sh_dc.detach().clone());
  sh_rest_.set_data(sh_rest.detach().clone());
  surface_weights_.set_data(surface_weights.detach().clone());
  skinning_corrections_.set_data(skinning_corrections.detach().clone());
  surface_anchors_.set_data(surface_anchors.detach().clone());
  for (auto* p : {&means_, &log_scales_, &rotations_, &opacity_logits_, &sh_dc_, &sh_rest_, &skinning_corrections_}) {
    p->mutable_grad() = torch::Tensor();
  }
}

}  // namespace fskin
