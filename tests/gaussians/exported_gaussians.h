#pragma once
// Shared by the export tests (PLY and glTF): an avatar whose every parameter
// varies, a renderer of Gaussians read back from a file, posed and drawn as
// the files' documentation says, by the tests' own code on fskin's ops, and
// its comparison with the avatar's own render.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <Eigen/Core>

#include <tuple>

#include "fskin/gaussians/gaussian_avatar.h"
#include "fskin/gaussians/gaussian_projection.h"
#include "fskin/gaussians/spherical_harmonics.h"
#include "fskin/ops/gaussian_rasterization.h"
#include "fskin/skeleton/lbs.h"

namespace fskin::testing {

// `count` Gaussians on the character with random colours (degree
// `sh_degree`), scales, rotations and opacities, drawn with a dilation of
// neither the default's nor 3DGS's (a reader must take the file's).
inline GaussianAvatar varied_gaussian_avatar(const RiggedMesh& character, int64_t count, int64_t sh_degree) {
  GaussianAvatarOptions options;
  options.initial_gaussians = count;
  options.sh_degree = sh_degree;
  options.dilation = 0.2;
  GaussianAvatar avatar(character, options, 3);
  torch::manual_seed(4);
  torch::NoGradGuard no_grad;
  avatar->sh_dc().normal_(0, 0.5);
  avatar->sh_rest().normal_(0, 0.3);
  avatar->log_scales().add_(torch::randn_like(avatar->log_scales()) * 0.3);
  avatar->rotations().normal_();
  avatar->opacity_logits().normal_(0, 1);
  return avatar;
}

// Canonical Gaussians as a file holds them, decoded: means [N, 3], rotation
// matrices [N, 3, 3], scales [N, 3] (standard deviations), opacities [N],
// spherical harmonics [N, K, 3], skinning weights [N, J].
struct FileGaussians {
  torch::Tensor means, rotations, scales, opacities, sh, weights;
  bool antialiased = false;
  double dilation = 0.3;  // pixels^2
};

// T = sum_j w_j B_j; mean' = T mean; covariance' = A R S S R^T A^T; colour at
// the view direction mapped back by A^T; opacities times the dilation's
// compensation when antialiased; dilated by the file's dilation; over a
// white background.
inline std::tuple<torch::Tensor, torch::Tensor> render_file_gaussians(const FileGaussians& g,
                                                                     const torch::Tensor& bones,
                                                                     const PinholeCamera& camera) {
  const auto transforms = blend_transforms(g.weights, bones.unsqueeze(0))[0];
  const auto linear = transforms.narrow(1, 0, 3).narrow(2, 0, 3);
  const auto posed_means = transform_points(transforms, g.means);
  const auto rs = g.rotations * g.scales.unsqueeze(1);
  const auto covariances =
      torch::matmul(torch::matmul(linear, torch::matmul(rs, rs.transpose(1, 2))), linear.transpose(1, 2));
  ProjectionOptions projection;
  projection.compensate = g.antialiased;
  projection.dilation = g.dilation;
  const auto projected = project_gaussians(posed_means, covariances, camera, projection);
  const Eigen::Vector3d eye = camera.centre();
  const auto eye_tensor = torch::tensor({eye.x(), eye.y(), eye.z()}).to(torch::kFloat32);
  const auto view =
      torch::matmul(linear.transpose(1, 2), (posed_means - eye_tensor).unsqueeze(-1)).squeeze(-1);
  const auto colors = spherical_harmonics_color(g.sh, view / view.norm(2, 1, true));
  const auto drawn = g.antialiased ? g.opacities * projected.opacity_compensation : g.opacities;
  return rasterize_gaussians(projected.means2d, projected.conics, colors, drawn, projected.depths, projected.radii,
                             torch::ones({3}), camera.width, camera.height);
}

// The file's Gaussians posed by `file_bones` render as `avatar` posed by
// `bones` (over white): every pixel's colour and alpha within `bound`, and
// the avatar covers a part of the picture worth comparing.
inline void expect_renders_as_avatar(const FileGaussians& g, const torch::Tensor& file_bones,
                                     GaussianAvatarImpl& avatar, const torch::Tensor& bones,
                                     const PinholeCamera& camera, double bound) {
  const auto [image, alpha] = render_file_gaussians(g, file_bones, camera);
  torch::NoGradGuard no_grad;
  const auto expected = avatar.render(bones, camera, {1, 1, 1});
  EXPECT_GT(expected.alpha.sum().item<double>(), 50.0);
  EXPECT_LT((image - expected.image).abs().max().item<double>(), bound);
  EXPECT_LT((alpha - expected.alpha).abs().max().item<double>(), bound);
}

}  // namespace fskin::testing
