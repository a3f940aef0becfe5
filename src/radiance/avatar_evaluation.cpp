#include "fskin/radiance/avatar_evaluation.h"

#include <algorithm>
#include <chrono>

#include <torch/torch.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/geometry/character_size.h"
#include "fskin/radiance/image_metrics.h"
#include "fskin/util/progress.h"

namespace fskin {

std::string AvatarEvaluation::to_json() const {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& f : frames)
    rows.push_back({{"index", f.index},
                    {"pose_index", f.pose_index},
                    {"view_index", f.view_index},
                    {"psnr", f.psnr},
                    {"ssim", f.ssim},
                    {"psnr_subject_box", f.psnr_subject_box},
                    {"render_seconds", f.render_seconds}});
  return nlohmann::json{{"split", split},
                        {"images", frames.size()},
                        {"mean_psnr", mean_psnr},
                        {"mean_ssim", mean_ssim},
                        {"mean_psnr_subject_box", mean_psnr_subject_box},
                        {"median_render_seconds", median_render_seconds},
                        {"pose_fitting_steps", pose_fitting_steps},
                        {"frames", rows}}
             .dump(2) +
         "\n";
}

std::string AvatarEvaluation::to_table() const {
  std::string out = fmt::format("{:<12} {:>6} {:>10} {:>8} {:>14} {:>10}\n", "split", "images", "PSNR (dB)", "SSIM",
                                "PSNR box (dB)", "render s");
  out += fmt::format("{:<12} {:>6} {:>10.2f} {:>8.4f} {:>14.2f} {:>10.3f}\n", split, frames.size(), mean_psnr,
                     mean_ssim, mean_psnr_subject_box, median_render_seconds);
  return out;
}

AvatarEvaluation evaluate_avatar(Avatar& avatar, const ImageDataset& data, const std::string& split_name,
                                 int64_t max_images, bool progress, const FrameInputsOf& inputs_of) {
  const FrameRenderer render = [&avatar](const FrameInputs& inputs, const PinholeCamera& camera,
                                         const std::array<double, 3>& background) {
    auto frame = avatar->pose(inputs.bones);
    frame.appearance = inputs.appearance;
    return avatar->render_image(frame, camera, background).first;
  };
  return evaluate_renders(render, data, split_name, max_images, progress, inputs_of);
}

AvatarEvaluation evaluate_renders(const FrameRenderer& render, const ImageDataset& data, const std::string& split_name,
                                  int64_t max_images, bool progress, const FrameInputsOf& inputs_of) {
  FSKIN_CHECK(max_images >= 0, "avatar eval: max images must be >= 0, got {}", max_images);
  const auto split = data.load_split(split_name);
  FSKIN_CHECK(split.size() > 0, "{}: split '{}' has no images", data.dir(), split_name);
  std::vector<int64_t> chosen;
  const int64_t n = max_images > 0 ? std::min(max_images, split.size()) : split.size();
  for (int64_t k = 0; k < n; ++k) chosen.push_back(k * split.size() / n);
  AvatarEvaluation out;
  out.split = split_name;
  ProgressBar bar("avatar eval " + split_name, n, progress);
  std::vector<double> seconds;
  for (const int64_t i : chosen) {
    const auto inputs = inputs_of ? inputs_of(split, i) : FrameInputs{split.bone_transforms[i], {}};
    const auto start = std::chrono::steady_clock::now();
    const auto rendered = render(inputs, split.cameras[i], data.background());
    AvatarFrameScore score;
    score.render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const auto truth = split.images[i].to(torch::kFloat32) / 255;
    score.index = i;
    score.pose_index = split.pose_index[i].item<int64_t>();
    score.view_index = split.view_index[i].item<int64_t>();
    score.psnr = psnr(rendered, truth);
    score.ssim = ssim(rendered, truth);
    const auto box = mask_box(split.masks[i]);  // the whole image for an empty mask
    const auto crop = [&](const torch::Tensor& image) {
      return image.slice(0, box[1], box[3]).slice(1, box[0], box[2]);
    };
    score.psnr_subject_box = psnr(crop(rendered), crop(truth));
    out.mean_psnr_subject_box += score.psnr_subject_box / static_cast<double>(n);
    out.mean_psnr += score.psnr / static_cast<double>(n);
    out.mean_ssim += score.ssim / static_cast<double>(n);
    seconds.push_back(score.render_seconds);
    out.frames.push_back(score);
    bar.advance(1, fmt::format("PSNR {:.2f}", score.psnr));
  }
  bar.finish();
  std::sort(seconds.begin(), seconds.end());
  out.median_render_seconds = seconds[seconds.size() / 2];
  return out;
}

AvatarEvaluation evaluate_avatar_run(const std::string& run_dir, const std::string& data_dir,
                                     const std::string& split, int64_t max_images, bool progress,
                                     const PoseFittingOptions& fitting) {
  auto trained = TrainedAvatar::load(run_dir);
  const ImageDataset data(data_dir.empty() ? trained.options.data_dir : data_dir);
  const auto& character = data.character();
  const double size = character_size(character.mesh.vertices, "avatar eval: canonical vertices");
  auto scores = evaluate_avatar(trained.avatar, data, split, max_images, progress,
                         [&](const ImageSplit& images, int64_t i) {
                           const auto& given = images.bone_transforms[i];
                           const auto appearance = trained.appearance_for(given);
                           const auto bones =
                               fit_pose_to_image(trained.avatar, images, i, trained.bones_for(given),
                                                 data.background(), character.skeleton, size, fitting, appearance);
                           return FrameInputs{bones, appearance};
                         });
  scores.pose_fitting_steps = fitting.steps;
  return scores;
}

}  // namespace fskin
