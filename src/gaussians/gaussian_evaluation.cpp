#include "fskin/gaussians/gaussian_evaluation.h"

#include "fskin/gaussians/gaussian_training.h"
#include "fskin/radiance/image_dataset.h"

namespace fskin {

AvatarEvaluation evaluate_gaussian_avatar_run(const std::string& run_dir, const std::string& data_dir,
                                              const std::string& split, int64_t max_images, bool progress) {
  auto trained = TrainedGaussianAvatar::load(run_dir);
  const ImageDataset data(data_dir.empty() ? trained.options.data_dir : data_dir);
  const FrameRenderer render = [&trained](const FrameInputs& inputs, const PinholeCamera& camera,
                                          const std::array<double, 3>& background) {
    return trained.render(inputs.bones, camera, background).first;
  };
  return evaluate_renders(render, data, split, max_images, progress);
}

}  // namespace fskin
