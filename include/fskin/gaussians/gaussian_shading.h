#pragma once
// Shading of a Gaussian avatar's colour by its posed surface (issue 36: under
// a fixed light a body's shade changes as a part turns and bends, which a
// colour held in canonical space cannot follow). With "irradiance" shading,
// a Gaussian's colour is its own (its spherical harmonics: the albedo, seen
// from the view direction) times one shade for the whole avatar, a function
// of the Gaussian's posed normal n:
//   shade(n) = max(0, sum_{k < 9} L_k Y_k(n) + 1/2)   per colour channel,
// a spherical-harmonic irradiance of degree 2 (the basis and offset of
// spherical_harmonics.h), which holds the light a Lambertian surface receives
// from any distant lighting to within a few per cent (Ramamoorthi and
// Hanrahan 2001, "An efficient representation for irradiance environment
// maps"). L starts as a shade of 1 everywhere: the unshaded avatar.
//
// The normal of a Gaussian is its local z axis: the avatar's discs start
// with it along their face's outward normal (gaussian_avatar.h), and
// densification passes it on to the Gaussians it makes. It is carried by the
// blended transform A as a plane's normal is (A^-T n, the cross product of the
// posed x and y axes), and keeps its side: a normal turned towards each
// camera would flip where a surface is seen edge-on, and its shade with it.
// The avatar shades with the normals detached: the shade learns the
// lighting and the albedo, never the Gaussians' orientation or the pose
// (through its normal each Gaussian could tilt to set its own shade, fitting
// the training views and drawing tilted footprints in the others: measured,
// docs/benchmarks.md).
#include <torch/torch.h>

namespace fskin {

// Posed normals [N, 3] (unit) of Gaussians with rotations [N, 4]
// (quaternions (w, x, y, z), unnormalised) and blended 3 x 3 transforms
// `linear` [N, 3, 3]. Differentiable in both.
torch::Tensor posed_gaussian_normals(const torch::Tensor& rotations, const torch::Tensor& linear);

class GaussianShadingImpl : public torch::nn::Module {
 public:
  GaussianShadingImpl();
  // normals [N, 3] -> shades [N, 3] (non-negative; 1 at the start).
  torch::Tensor forward(const torch::Tensor& normals);
  // The lighting's coefficients [9, 3] (a parameter).
  torch::Tensor& lighting() { return lighting_; }

 private:
  torch::Tensor lighting_;
};
TORCH_MODULE(GaussianShading);

}  // namespace fskin
