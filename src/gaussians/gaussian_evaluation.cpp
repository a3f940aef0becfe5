#include "fskin/gaussians/gaussian_evaluation.h"

#include "fskin/geometry/character_size.h"
#include "fskin/gaussians/gaussian_pose_fitting.h"
#include "fskin/gaussians/gaussian_training.h"
#include "fskin/radiance/image_dataset.h"

namespace fskin {

AvatarEvaluation evaluate_gaussian_avatar_run(const std::string& run_dir, const std::string& data_dir,
                                              const std::string& split, int64_t max_images, bool progress,
                                              const PoseFittingOptions& fitting) {
  auto trained = TrainedGaussianAvatar::load(run_dir);
  const ImageDataset data(data_dir.empty() ? trained.options.data_dir : data_dir);
  const FrameRenderer render = [&trained](const FrameInputs& inputs, const PinholeCamera& camera,
                                          const std::array<double, 3>& background) {
    return trained.render(inputs.bones, camera, background, inputs.appearance).first;
  };
  const auto& character = data.character();
  const double size = character_size(character.mesh.vertices, "avatar eval: canonical vertices");
  // The novel views of training poses with their refined bones, as the volume
  // avatar's (avatar_evaluation.h), fitted when asked.
  const FrameInputsOf inputs_of = [&](const ImageSplit& images, int64_t i) {
    const auto appearance = trained.appearance_for(images.bone_transforms[i]);
    const auto bones = fit_gaussian_pose_to_image(*trained.avatar, images, i,
                                                  trained.bones_for(images.bone_transforms[i]), data.background(),
                                                  character.skeleton, size, trained.options.mask_weight, fitting,
                                                  appearance);
    return FrameInputs{bones, appearance};
  };
  auto scores = evaluate_renders(render, data, split, max_images, progress, inputs_of);
  scores.pose_fitting_steps = fitting.steps;
  return scores;
}

AvatarEvaluation evaluate_baked_gaussian_mesh(const std::string& run_dir, const std::string& data_dir,
                                              const std::string& split, int64_t max_images, bool progress,
                                              const GaussianBakingOptions& baking) {
  auto trained = TrainedGaussianAvatar::load(run_dir);
  const ImageDataset data(data_dir.empty() ? trained.options.data_dir : data_dir);
  const auto baked = baked_gaussian_mesh(*trained.avatar, data.character(), baking);
  const FrameRenderer render = [&](const FrameInputs& inputs, const PinholeCamera& camera,
                                   const std::array<double, 3>& background) {
    return render_baked_mesh(baked, inputs.bones, camera, background);
  };
  const FrameInputsOf inputs_of = [&](const ImageSplit& images, int64_t i) {
    return FrameInputs{trained.bones_for(images.bone_transforms[i]), {}};
  };
  return evaluate_renders(render, data, split, max_images, progress, inputs_of);
}

}  // namespace fskin
