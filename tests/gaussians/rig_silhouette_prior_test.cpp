// The rig silhouette prior: the rig's posed coverage is the mask an image
// dataset draws for the same pose and camera, and a short training with the
// prior draws the held-out views' outlines closer to their masks.
#include "fskin/gaussians/rig_silhouette_prior.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "gaussians/tiny_gaussian_training.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

TEST(RigSilhouettePrior, TheRigsCoverageIsTheDatasetsMask) {
  const auto& tiny = testing::tiny_image_dataset();
  const ImageDataset data(tiny.dir);
  for (const char* name : {"train", "novel_pose"}) {
    const auto split = data.load_split(name);
    for (int64_t i = 0; i < split.size(); ++i) {
      const auto coverage =
          posed_rig_coverage(data.character(), split.bone_transforms[i], split.cameras[i], tiny.options.supersampling);
      const auto mask = split.masks[i].to(torch::kFloat32) / 255;
      ASSERT_EQ(coverage.sizes(), mask.sizes());
      EXPECT_GT(mask.sum().item<double>(), 20) << name << " image " << i;
      // The builder poses the body model itself: from its rest pose, with its
      // pose-corrective shapes, where the rig poses its canonical (Da-pose)
      // mesh by linear blend skinning alone. Samples near the hips and the
      // shoulders fall the other way: about 2 % of the area.
      const double differ = (coverage - mask).abs().sum().item<double>(), area = mask.sum().item<double>();
      EXPECT_LT(differ, 0.03 * area) << name << " image " << i << ": " << differ << " of " << area;
      // Another image's mask is far from it.
      const auto other = split.masks[(i + 1) % split.size()].to(torch::kFloat32) / 255;
      EXPECT_GT((coverage - other).abs().sum().item<double>(), 0.1 * area) << name << " image " << i;
    }
  }
}

// The mean L1 distance between the trained avatar's opacity and the masks over the held-out views.
double held_out_outline_error(const std::string& run) {
  return testing::mean_over_held_out_views(run, [](const torch::Tensor& alpha, const torch::Tensor& mask) {
    return (alpha - mask).abs().mean().item<double>();
  });
}

TEST(RigSilhouettePrior, TrainingWithItDrawsTheHeldOutOutlinesCloserToTheirMasks) {
  auto without = testing::tiny_gaussian_training("rig_silhouette_prior_without", 150);
  auto every_step = testing::tiny_gaussian_training("rig_silhouette_prior_every_step", 150);
  auto defaults = testing::tiny_gaussian_training("rig_silhouette_prior_defaults", 150);
  without.rig_silhouette_weight = 0;
  every_step.unseen_view_every = 1;
  for (auto* options : {&without, &every_step, &defaults}) train_gaussian_avatar(*options);
  const double plain = held_out_outline_error(without.out_dir);
  const double prior = held_out_outline_error(every_step.out_dir);
  const double sparse = held_out_outline_error(defaults.out_dir);  // drawn on one step in 4
  EXPECT_LT(prior, 0.8 * plain) << "without " << plain << ", every step " << prior;
  EXPECT_LT(sparse, 0.9 * plain) << "without " << plain << ", one step in 4 " << sparse;
}

}  // namespace
}  // namespace fskin
