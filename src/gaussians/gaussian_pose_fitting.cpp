#include "fskin/gaussians/gaussian_pose_fitting.h"

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <atomic>
#include <mutex>

#include "fskin/core/error.h"
#include "fskin/radiance/image_rays.h"
#include "fskin/util/progress.h"

namespace fskin {

namespace {

// The fitting loss of one pose seen by images of a split: per image, the mean
// L1 on colour plus mask_weight x the mean L1 between alpha and mask, over the
// image's mask box grown by 20 %; the mean over the images. The Gaussians are
// rendered with the pose's appearance code (undefined: code zero).
class ViewsLoss {
 public:
  ViewsLoss(const ImageSplit& split, const std::vector<int64_t>& images, const std::array<double, 3>& background,
            double mask_weight)
      : background_(background), mask_weight_(mask_weight) {
    FSKIN_CHECK(!images.empty(), "gaussian pose fitting: no images to fit the pose to");
    for (const int64_t image : images) {
      FSKIN_CHECK(image >= 0 && image < split.size(), "gaussian pose fitting: image {} is outside the split's {}",
                  image, split.size());
      const auto box = mask_box(split.masks[image], 0.2);  // (u0, v0, u1, v1)
      const auto crop = [&](const torch::Tensor& t) { return t.slice(0, box[1], box[3]).slice(1, box[0], box[2]); };
      views_.push_back({split.cameras[static_cast<size_t>(image)].cropped(box[0], box[1], box[2], box[3]),
                        crop(split.images[image]).to(torch::kFloat32) / 255,
                        crop(split.masks[image]).to(torch::kFloat32) / 255});
    }
  }

  torch::Tensor operator()(GaussianAvatarImpl& avatar, const torch::Tensor& bones,
                           const torch::Tensor& appearance) const {
    const auto posed = avatar.pose(bones);  // once for every view
    torch::Tensor loss;
    for (const auto& view : views_) {
      const auto rendered = avatar.render(posed, view.camera, background_, appearance);
      const auto term =
          (rendered.image - view.target).abs().mean() + mask_weight_ * (rendered.alpha - view.mask).abs().mean();
      loss = loss.defined() ? loss + term : term;
    }
    return loss / static_cast<double>(views_.size());
  }

 private:
  struct View {
    PinholeCamera camera;
    torch::Tensor target, mask;  // [h, w, 3], [h, w] in [0, 1], cut to the box
  };
  std::vector<View> views_;
  std::array<double, 3> background_;
  double mask_weight_;
};

}  // namespace

torch::Tensor fit_gaussian_pose_to_image(GaussianAvatarImpl& avatar, const ImageSplit& split, int64_t image,
                                         const torch::Tensor& bones, const std::array<double, 3>& background,
                                         const Skeleton& skeleton, double size, double mask_weight,
                                         const PoseFittingOptions& options, const torch::Tensor& appearance) {
  options.validate();
  if (options.steps == 0) return bones.detach().to(torch::kCPU, torch::kFloat32).contiguous();  // no crops to make
  const ViewsLoss loss(split, {image}, background, mask_weight);
  const auto code = appearance.defined() ? appearance.detach() : appearance;
  return fit_pose(bones, skeleton, size, options, avatar.parameters(),
                  [&](const torch::Tensor& corrected, int64_t) { return loss(avatar, corrected, code); });
}

bool fit_gaussian_training_poses(GaussianAvatarImpl& avatar, const ImageSplit& split,
                                 const std::vector<int64_t>& frame_of, PoseCorrectionsImpl& corrections,
                                 const AppearanceCodesImpl* appearance, const std::array<double, 3>& background,
                                 const Skeleton& skeleton, double size, double mask_weight,
                                 const PoseFittingOptions& options, bool progress, const StopSignal* stop) {
  options.validate();
  FSKIN_CHECK(static_cast<int64_t>(frame_of.size()) == split.size(),
              "gaussian pose fitting: {} frame numbers for {} images", frame_of.size(), split.size());
  if (options.steps == 0) return true;
  FSKIN_CHECK(!appearance || appearance->frames() == corrections.frames(),
              "gaussian pose fitting: {} appearance codes for {} frames", appearance ? appearance->frames() : 0,
              corrections.frames());
  std::vector<std::vector<int64_t>> views(static_cast<size_t>(corrections.frames()));
  for (size_t i = 0; i < frame_of.size(); ++i) {
    FSKIN_CHECK(frame_of[i] >= 0 && frame_of[i] < corrections.frames(),
                "gaussian pose fitting: image {} sees frame {} of {}", i, frame_of[i], corrections.frames());
    views[static_cast<size_t>(frame_of[i])].push_back(static_cast<int64_t>(i));
  }
  const auto parameters = avatar.parameters();
  const FrozenParameters freeze(parameters);  // once for all frames: they are fitted side by side
  ProgressBar bar("fitting the training poses", corrections.frames(), progress);
  std::mutex bar_mutex;
  std::atomic<bool> stopped{false};
  const auto fit_frames = [&](int64_t begin, int64_t end) {
    for (int64_t f = begin; f < end; ++f) {
      if (stopped || (stop && stop->requested())) {
        stopped = true;
        return;
      }
      if (!views[static_cast<size_t>(f)].empty()) {
        const ViewsLoss loss(split, views[static_cast<size_t>(f)], background, mask_weight);
        const auto code = appearance ? appearance->code(f).detach() : torch::Tensor();
        fit_pose_correction(corrections, f, skeleton, size, options, /*frozen=*/{},
                            [&](const torch::Tensor& corrected, int64_t) { return loss(avatar, corrected, code); });
      }
      const std::lock_guard<std::mutex> lock(bar_mutex);
      bar.advance();
    }
  };
  // The frames are independent. On the CPU they are fitted side by side, a
  // thread each, the ops inside at::parallel_for running serially: most of a
  // step's ops act on one value per Gaussian, about 30,000, under LibTorch's
  // grain size (32,768), and use one core whatever the thread count, so one
  // frame at a time leaves the others idle (BM_GaussianPoseFit,
  // docs/benchmarks.md). A frame's arithmetic is the same on any thread: the
  // fit does not depend on the thread count. A GPU fits one after another.
  if (!parameters.empty() && parameters.front().is_cuda()) {
    fit_frames(0, corrections.frames());
  } else {
    at::parallel_for(0, corrections.frames(), 1, fit_frames);
  }
  return !stopped;
}

}  // namespace fskin
