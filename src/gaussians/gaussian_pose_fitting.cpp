#include "fskin/gaussians/gaussian_pose_fitting.h"

#include <torch/torch.h>

#include "fskin/radiance/image_rays.h"

namespace fskin {

torch::Tensor fit_gaussian_pose_to_image(GaussianAvatarImpl& avatar, const ImageSplit& split, int64_t image,
                                         const torch::Tensor& bones, const std::array<double, 3>& background,
                                         const Skeleton& skeleton, double size, double mask_weight,
                                         const PoseFittingOptions& options) {
  options.validate();
  if (options.steps == 0) return bones.detach().to(torch::kCPU, torch::kFloat32).contiguous();  // no crops to make
  const auto box = mask_box(split.masks[image], 0.2);  // (u0, v0, u1, v1)
  const auto camera = split.cameras[static_cast<size_t>(image)].cropped(box[0], box[1], box[2], box[3]);
  const auto crop = [&](const torch::Tensor& t) { return t.slice(0, box[1], box[3]).slice(1, box[0], box[2]); };
  const auto target = crop(split.images[image]).to(torch::kFloat32) / 255;
  const auto mask = crop(split.masks[image]).to(torch::kFloat32) / 255;
  return fit_pose(bones, skeleton, size, options, avatar.parameters(),
                  [&](const torch::Tensor& corrected, int64_t) {
                    const auto rendered = avatar.render(corrected, camera, background);
                    return (rendered.image - target).abs().mean() + mask_weight * (rendered.alpha - mask).abs().mean();
                  });
}

}  // namespace fskin
