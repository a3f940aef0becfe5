#include "fskin/radiance/pose_fitting.h"

#include <array>
#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/radiance/image_rays.h"
#include "fskin/radiance/pose_correction.h"

namespace fskin {

void PoseFittingOptions::validate() const {
  FSKIN_CHECK(steps >= 0 && rays >= 1, "pose fitting: steps must be >= 0 and rays >= 1, got {} and {}", steps, rays);
  for (const double rate : {learning_rate, translation_learning_rate})
    FSKIN_CHECK(rate > 0 && rate <= 1, "pose fitting: the learning rate {} must be in (0, 1]", rate);
  FSKIN_CHECK(std::isfinite(regularizer) && regularizer >= 0, "pose fitting: the regulariser must be >= 0, got {}",
              regularizer);
}

FrozenParameters::FrozenParameters(std::vector<torch::Tensor> parameters) : parameters_(std::move(parameters)) {
  for (auto& t : parameters_) {
    required_.push_back(t.requires_grad());
    t.requires_grad_(false);
  }
}

FrozenParameters::~FrozenParameters() {
  for (size_t k = 0; k < parameters_.size(); ++k) parameters_[k].requires_grad_(required_[k]);
}

torch::Tensor fit_pose(const torch::Tensor& bones, const Skeleton& skeleton, double size,
                       const PoseFittingOptions& options, const std::vector<torch::Tensor>& frozen,
                       const PoseImageLoss& image_loss) {
  options.validate();
  const auto given = bones.detach().to(torch::kCPU, torch::kFloat32).contiguous();
  if (options.steps == 0) return given;
  PoseCorrections correction(given.unsqueeze(0));
  fit_pose_correction(*correction, 0, skeleton, size, options, frozen, image_loss);
  return correction->corrected(skeleton, size)[0];
}

void fit_pose_correction(PoseCorrectionsImpl& corrections, int64_t frame, const Skeleton& skeleton, double size,
                         const PoseFittingOptions& options, const std::vector<torch::Tensor>& frozen,
                         const PoseImageLoss& image_loss) {
  options.validate();
  FSKIN_CHECK(frame >= 0 && frame < corrections.frames(), "pose fitting: frame {} of {} frames", frame,
              corrections.frames());
  if (options.steps == 0) return;
  const FrozenParameters freeze(frozen);  // only the correction learns
  const auto f = static_cast<size_t>(frame);
  const std::array<double, 2> rates{options.learning_rate, options.translation_learning_rate};
  std::vector<torch::optim::OptimizerParamGroup> groups;
  groups.emplace_back(std::vector<torch::Tensor>{corrections.rotation_parameters()[f]},
                      std::make_unique<torch::optim::AdamOptions>(rates[0]));
  groups.emplace_back(std::vector<torch::Tensor>{corrections.translation_parameters()[f]},
                      std::make_unique<torch::optim::AdamOptions>(rates[1]));
  torch::optim::Adam adam(std::move(groups), torch::optim::AdamOptions(rates[0]));
  for (int64_t step = 0; step < options.steps; ++step) {
    // Cosine decay to zero: the last steps settle instead of stepping about the optimum.
    const double decay = 0.5 * (1 + std::cos(M_PI * static_cast<double>(step) / static_cast<double>(options.steps)));
    for (size_t g = 0; g < rates.size(); ++g)
      static_cast<torch::optim::AdamOptions&>(adam.param_groups()[g].options()).lr(rates[g] * decay);
    const auto loss = image_loss(corrections.apply(frame, skeleton, size), step) +
                      options.regularizer * corrections.squared_size({frame});
    adam.zero_grad();
    loss.backward();
    adam.step();
  }
}

torch::Tensor fit_pose_to_image(Avatar& avatar, const ImageSplit& split, int64_t image, const torch::Tensor& bones,
                                const std::array<double, 3>& dataset_background, const Skeleton& skeleton, double size,
                                const PoseFittingOptions& options, const torch::Tensor& appearance) {
  options.validate();
  if (options.steps == 0) return bones.detach().to(torch::kCPU, torch::kFloat32).contiguous();
  const auto background = torch::tensor({dataset_background[0], dataset_background[1], dataset_background[2]},
                                        torch::kFloat32);
  const auto box = mask_box(split.masks[image], 0.2);
  // The posed grids of the given pose (dilated by a cell) hold the small corrections' samples.
  PosedFrame frame = avatar->pose(bones.detach().to(torch::kCPU, torch::kFloat32));
  frame.appearance = appearance;
  return fit_pose(bones, skeleton, size, options, avatar->parameters(),
                  [&](const torch::Tensor& corrected, int64_t step) {
                    torch::manual_seed(options.seed + static_cast<uint64_t>(step));
                    const auto rays =
                        sample_image_rays(split, image, box, options.rays, 0.9, "dataset", background);
                    frame.bones = corrected;
                    const auto rendered = avatar->render_rays(frame, rays.origins, rays.directions,
                                                              rays.background, /*jitter=*/false);
                    return avatar_ray_loss(rendered.color, rendered.opacity, rays.target, rays.mask,
                                           options.huber_delta, options.opacity_weight)
                        .total();
                  });
}

}  // namespace fskin
