#include "fskin/gaussians/rig_silhouette_prior.h"

#include "fskin/core/error.h"
#include "fskin/export/render.h"

namespace fskin {

torch::Tensor posed_rig_coverage(const RiggedMesh& character, const torch::Tensor& bones,
                                 const PinholeCamera& camera, int supersampling) {
  torch::NoGradGuard no_grad;
  const auto posed = posed_vertices(character, bones.detach());
  const SurfaceShader flat = [](int64_t, float, float, float) { return Eigen::Vector3f::Zero(); };
  const Mesh mesh{posed.contiguous(), character.mesh.faces.contiguous(), {}};
  auto picture = render_surface(mesh, camera, supersampling, flat, Rgb8{255, 255, 255});
  const auto mask = torch::from_blob(picture.mask.data(), {camera.height, camera.width}, torch::kUInt8);
  return mask.to(torch::kFloat32) / 255;  // a copy: the picture's buffer goes with it
}

}  // namespace fskin
