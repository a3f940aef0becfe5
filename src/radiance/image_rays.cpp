#include "fskin/radiance/image_rays.h"

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/geometry/pinhole_camera.h"

namespace fskin {

ImageRays sample_image_rays(const ImageSplit& split, int64_t image, const std::array<int64_t, 4>& box, int64_t count,
                            double box_fraction, const std::string& background, const torch::Tensor& dataset_background) {
  FSKIN_CHECK(image >= 0 && image < split.size(), "image rays: image {} of {}", image, split.size());
  const int64_t H = split.images.size(1), W = split.images.size(2);
  const int64_t in_box = static_cast<int64_t>(std::llround(box_fraction * static_cast<double>(count)));
  const auto u = torch::cat({torch::randint(box[0], box[2], {in_box}, torch::kInt64),
                             torch::randint(0, W, {count - in_box}, torch::kInt64)});
  const auto v = torch::cat({torch::randint(box[1], box[3], {in_box}, torch::kInt64),
                             torch::randint(0, H, {count - in_box}, torch::kInt64)});
  const auto flat = v * W + u;
  const auto rgb = split.images[image].reshape({-1, 3}).index_select(0, flat).to(torch::kFloat32) / 255;
  ImageRays out;
  out.mask = split.masks[image].reshape({-1}).index_select(0, flat).to(torch::kFloat32) / 255;
  if (background == "random") out.background = torch::rand({count, 3});
  else if (background == "white") out.background = torch::ones({count, 3});
  else if (background == "black") out.background = torch::zeros({count, 3});
  else out.background = dataset_background.expand({count, 3});
  // The image is the subject over the dataset's background: re-composite it over this one.
  out.target = rgb + (1 - out.mask).unsqueeze(1) * (out.background - dataset_background);
  std::tie(out.origins, out.directions) =
      camera_rays(split.cameras[image], torch::stack({u, v}, 1).to(torch::kFloat32));
  return out;
}

RayLoss avatar_ray_loss(const torch::Tensor& color, const torch::Tensor& opacity, const torch::Tensor& target,
                        const torch::Tensor& mask, double huber_delta, double opacity_weight) {
  return {torch::huber_loss(color, target, at::Reduction::Mean, huber_delta),
          opacity_weight * (opacity - mask).abs().mean()};
}

}  // namespace fskin
