#include "fskin/gaussians/gaussian_training.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/engine/checkpoint.h"
#include "fskin/engine/run_directory.h"
#include "fskin/engine/run_lock.h"
#include "fskin/engine/trainer.h"
#include "fskin/geometry/character_size.h"
#include "fskin/gaussians/gaussian_config.h"
#include "fskin/gaussians/gaussian_pose_fitting.h"
#include "fskin/gaussians/opacity_prior.h"
#include "fskin/gaussians/rig_silhouette_prior.h"
#include "fskin/gaussians/surface_layer.h"
#include "fskin/gaussians/unseen_view_prior.h"
#include "fskin/radiance/avatar_character.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/image_metrics.h"
#include "fskin/util/atomic_file.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

constexpr const char* kGaussianArchiveKey = "gaussian_avatar";
constexpr const char* kPoseCorrectionsKey = "pose_corrections";  // inside the avatar's archive
constexpr const char* kAppearanceCodesKey = "appearance_codes";    // inside the avatar's archive

std::string run_file(const std::string& run_dir) { return RunDirectory(run_dir).gaussian_avatar_config_file(); }

TrainerSettings trainer_settings(const GaussianTrainOptions& options, const std::string& label) {
  TrainerSettings settings;
  settings.steps = options.steps;
  settings.seed = options.seed;
  settings.schedule.decay_fraction = options.decay_fraction;
  settings.schedule.decay_factor = options.decay_factor;
  settings.learning_rate = options.means_learning_rate;
  settings.adam_eps = 1e-15;  // 3DGS's
  settings.log_every = options.log_every;
  settings.checkpoint_every = options.checkpoint_every;
  settings.resume = options.resume;
  settings.progress = options.progress;
  settings.progress_label = label;
  settings.learning_rate_hint = "lower the learning rates (--set optimizer.learning_rates.means=...)";
  settings.stop = options.stop;
  return settings;
}

}  // namespace

void GaussianTrainOptions::validate() const {
  avatar.validate();
  density.validate();
  FSKIN_CHECK(steps >= 0, "gaussian avatar train: steps must be >= 0, got {}", steps);
  for (const double rate : {means_learning_rate, scales_learning_rate, rotations_learning_rate, opacity_learning_rate,
                            sh_learning_rate, skinning_learning_rate, non_rigid_learning_rate, pose_learning_rate,
                            pose_translation_learning_rate, pose_second_pass_learning_rate, shading_learning_rate,
                            appearance_learning_rate}) {
    FSKIN_CHECK(std::isfinite(rate) && rate > 0 && rate <= 1,
                "gaussian avatar train: learning rates must be in (0, 1], got {}", rate);
  }
  FSKIN_CHECK(decay_fraction >= 0 && decay_fraction <= 1 && decay_factor > 0 && decay_factor <= 1,
              "gaussian avatar train: decay fraction must be within [0, 1] and decay factor within (0, 1]");
  FSKIN_CHECK(ssim_weight >= 0 && ssim_weight <= 1, "gaussian avatar train: the SSIM weight must be within [0, 1]");
  FSKIN_CHECK(std::isfinite(mask_weight) && mask_weight >= 0, "gaussian avatar train: the mask weight must be >= 0");
  FSKIN_CHECK(std::isfinite(non_rigid_weight) && non_rigid_weight >= 0,
              "gaussian avatar train: losses.non_rigid.weight must be >= 0, got {}", non_rigid_weight);
  FSKIN_CHECK(std::isfinite(layer_weight) && layer_weight >= 0,
              "gaussian avatar train: losses.surface_layer.weight must be >= 0, got {}", layer_weight);
  FSKIN_CHECK(std::isfinite(opacity_weight) && opacity_weight >= 0,
              "gaussian avatar train: losses.opacity.weight must be >= 0, got {}", opacity_weight);
  FSKIN_CHECK(std::isfinite(alpha_entropy_weight) && alpha_entropy_weight >= 0,
              "gaussian avatar train: losses.alpha_entropy.weight must be >= 0, got {}", alpha_entropy_weight);
  FSKIN_CHECK(std::isfinite(unseen_view_degrees) && unseen_view_degrees >= 0 && unseen_view_degrees <= 180,
              "gaussian avatar train: losses.unseen_view.degrees must be within [0, 180], got {}",
              unseen_view_degrees);
  FSKIN_CHECK(unseen_view_every >= 1, "gaussian avatar train: losses.unseen_view.every must be >= 1, got {}",
              unseen_view_every);
  FSKIN_CHECK(std::isfinite(rig_silhouette_weight) && rig_silhouette_weight >= 0,
              "gaussian avatar train: losses.rig_silhouette.weight must be >= 0, got {}", rig_silhouette_weight);
  FSKIN_CHECK(std::isfinite(pose_regularizer) && pose_regularizer >= 0,
              "gaussian avatar train: pose_refinement.regularizer must be >= 0, got {}", pose_regularizer);
  FSKIN_CHECK(pose_first_pass_steps >= 0, "gaussian avatar train: pose_refinement.first_pass_steps must be >= 0, got {}",
              pose_first_pass_steps);
  FSKIN_CHECK(pose_fit_steps >= 0, "gaussian avatar train: pose_refinement.fit_steps must be >= 0, got {}",
              pose_fit_steps);
  FSKIN_CHECK(pose_fit_rounds >= 1, "gaussian avatar train: pose_refinement.fit_rounds must be >= 1, got {}",
              pose_fit_rounds);
  FSKIN_CHECK(std::isfinite(skinning_weight) && skinning_weight >= 0,
              "gaussian avatar train: the skinning prior's weight must be >= 0");
  FSKIN_CHECK(std::isfinite(crop_margin) && crop_margin <= 10,
              "gaussian avatar train: the crop margin must be <= 10 (< 0: whole pictures), got {}", crop_margin);
  FSKIN_CHECK(checkpoint_every >= 1 && log_every >= 1,
              "gaussian avatar train: checkpoint and log intervals must be >= 1");
}

bool is_gaussian_avatar_run(const std::string& run_dir) { return fs::exists(run_file(run_dir)); }

namespace {

// The Gaussian avatar as the engine trains it (engine/trainable.h).
class GaussianTrainable : public Trainable {
 public:
  // poses_frozen: the pose corrections are applied as they are, not learned
  // (the pass after the training poses were fitted).
  GaussianTrainable(GaussianAvatar avatar, const GaussianTrainOptions& options, const ImageDataset& data,
                    const ImageSplit& split, bool poses_frozen = false)
      : avatar_(std::move(avatar)),
        poses_frozen_(poses_frozen),
        options_(options),
        split_(split),
        background_(data.background()),
        size_(character_size(data.character().mesh.vertices, "gaussian avatar train: canonical vertices")),
        skeleton_(data.character().skeleton),
        character_(data.character()),
        frame_(frames_of_images(split.bone_transforms)) {
    statistics_.reset(avatar_->size());
    // One correction per pose, shared by the views that see it.
    if (options.refine_poses) corrections_ = PoseCorrections(frame_bone_transforms(split.bone_transforms, frame_));
    // One code per pose too: a frame's light is the same from each view.
    if (avatar_->appearance()) {
      appearance_ = AppearanceCodes(frame_bone_transforms(split.bone_transforms, frame_), avatar_->appearance()->dim());
    }
    for (int64_t i = 0; i < split.size(); ++i) {
      const int64_t w = split.images.size(2), h = split.images.size(1);
      FSKIN_CHECK(w >= 11 && h >= 11, "gaussian avatar train: images must be at least 11 x 11 (SSIM), got {} x {}", w,
                  h);
      auto box = options.crop_margin < 0 ? std::array<int64_t, 4>{0, 0, w, h}
                                         : mask_box(split.masks[i], options.crop_margin);
      // At least SSIM's 11 x 11 window: a box too small grows about its centre, within the picture.
      for (const int axis : {0, 1}) {
        const int64_t size = axis == 0 ? w : h;
        int64_t& low = box[axis];
        int64_t& high = box[axis + 2];
        const int64_t length = std::max<int64_t>(11, high - low);
        low = std::clamp<int64_t>((low + high - length) / 2, 0, size - length);
        high = low + length;
      }
      boxes_.push_back(box);
    }
  }

  std::vector<OptimizerGroup> optimizer_groups() override {
    std::vector<OptimizerGroup> groups{{{avatar_->means()}, options_.means_learning_rate * size_},
            {{avatar_->log_scales()}, options_.scales_learning_rate},
            {{avatar_->rotations()}, options_.rotations_learning_rate},
            {{avatar_->opacity_logits()}, options_.opacity_learning_rate},
            {{avatar_->sh_dc()}, options_.sh_learning_rate},
            {{avatar_->sh_rest()}, options_.sh_learning_rate / 20},
            // [N, 0] without learned skinning: nothing to step.
            {{avatar_->skinning_corrections()}, options_.skinning_learning_rate}};
    if (avatar_->non_rigid_offset()) {
      groups.push_back({avatar_->non_rigid_offset()->parameters(), options_.non_rigid_learning_rate});
    }
    if (avatar_->shading()) groups.push_back({avatar_->shading()->parameters(), options_.shading_learning_rate});
    if (appearance_) {
      groups.push_back({avatar_->appearance()->parameters(), options_.appearance_learning_rate});
      groups.push_back({appearance_->parameters(), options_.appearance_learning_rate});
    }
    if (corrections_ && !poses_frozen_) {
      groups.push_back({corrections_->rotation_parameters(), options_.pose_learning_rate});
      groups.push_back({corrections_->translation_parameters(), options_.pose_translation_learning_rate});
    }
    return groups;
  }
  std::vector<torch::Tensor> parameters() override {
    auto all = avatar_->parameters();
    if (corrections_ && !poses_frozen_) {
      for (const auto& p : corrections_->parameters()) all.push_back(p);
    }
    if (appearance_) {
      for (const auto& p : appearance_->parameters()) all.push_back(p);
    }
    return all;
  }

  void save(torch::serialize::OutputArchive& archive) override {
    torch::serialize::OutputArchive model;
    avatar_->save(model);
    // The density statistics, so that a resumed run densifies as an uninterrupted one.
    model.write("density_sum", statistics_.sum());
    model.write("density_count", statistics_.count());
    if (corrections_) {
      torch::serialize::OutputArchive poses;
      corrections_->save(poses);
      model.write(kPoseCorrectionsKey, poses);
    }
    if (appearance_) {
      torch::serialize::OutputArchive codes;
      appearance_->save(codes);
      model.write(kAppearanceCodesKey, codes);
    }
    archive.write(kGaussianArchiveKey, model);
  }
  void load(torch::serialize::InputArchive& archive) override {
    torch::serialize::InputArchive model;
    archive.read(kGaussianArchiveKey, model);
    avatar_->load(model);
    torch::Tensor sum, count;
    model.read("density_sum", sum);
    model.read("density_count", count);
    statistics_.restore(sum, count);
    if (corrections_) {
      torch::serialize::InputArchive poses;
      model.read(kPoseCorrectionsKey, poses);
      corrections_->load(poses);
    }
    if (appearance_) {
      torch::serialize::InputArchive codes;
      model.read(kAppearanceCodesKey, codes);
      appearance_->load(codes);
    }
  }
  void to(const torch::Device& device) override {
    FSKIN_CHECK(device.is_cpu(), "gaussian avatar train: trains on the CPU only so far (asked for {})", device.str());
  }

  StepLosses step_losses(int64_t step, uint64_t seed, const Shard& shard) override {
    (void)seed;
    FSKIN_CHECK(shard.count == 1, "gaussian avatar train: data-parallel ranks are not supported yet");
    const int64_t i = torch::randint(split_.size(), {1}, torch::kInt64).item<int64_t>();
    const auto& camera = split_.cameras[static_cast<size_t>(i)];
    const auto& box = boxes_[static_cast<size_t>(i)];  // (u0, v0, u1, v1)
    // The camera of the box: the same rays, the picture cut to it.
    const PinholeCamera cropped = camera.cropped(box[0], box[1], box[2], box[3]);
    torch::Tensor bones = split_.bone_transforms[i];
    if (corrections_ && poses_frozen_) {
      bones = corrections_->apply(frame_[i], skeleton_, size_).detach();
    } else if (corrections_) {
      // Only this step's frame gets a gradient (Adam leaves the others be);
      // the corrections stay zero-mean over the frames (PoseCorrectionsImpl::center).
      corrections_->forget_gradients();
      corrections_->center();
      bones = corrections_->apply(frame_[i], skeleton_, size_);
    }
    torch::Tensor code;
    if (appearance_) {
      // As the corrections: this frame's code alone steps, the codes stay zero-mean.
      appearance_->forget_gradients();
      appearance_->center();
      code = appearance_->code(frame_[i]);
    }
    const auto posed = avatar_->pose(bones);
    last_ = avatar_->render(posed, cropped, background_, code);
    last_.means2d.retain_grad();
    // Density statistics in the whole picture's normalised coordinates.
    last_width_ = camera.width;
    last_height_ = camera.height;
    const auto crop = [&](const torch::Tensor& t) { return t.slice(0, box[1], box[3]).slice(1, box[0], box[2]); };
    const auto target = crop(split_.images[i]).to(torch::kFloat32) / 255;
    const auto mask = crop(split_.masks[i]).to(torch::kFloat32) / 255;
    // Means over the whole picture: the box's sums over its pixel count (and
    // SSIM window count); outside the box the picture is the exact background.
    const double pixels = static_cast<double>(camera.width) * camera.height;
    const double windows = static_cast<double>(camera.width - 10) * (camera.height - 10);
    const double box_windows = static_cast<double>(cropped.width - 10) * (cropped.height - 10);
    const auto l1 = (last_.image - target).abs().sum() / (3 * pixels);
    const auto structure = (1 - ssim_tensor(last_.image, target)) * (box_windows / windows);
    const auto mask_loss = (last_.alpha - mask).abs().sum() / pixels;
    const double w = options_.ssim_weight;
    StepLosses out;
    const auto colour = (1 - w) * l1, ssim_term = w * structure, mask_term = options_.mask_weight * mask_loss;
    out.total = colour + ssim_term + mask_term;
    out.terms = {{"l1", colour.detach()}, {"ssim", ssim_term.detach()}, {"mask", mask_term.detach()}};
    if (options_.avatar.learned_skinning && options_.skinning_weight > 0) {
      const auto prior = options_.skinning_weight * avatar_->skinning_corrections().square().mean();
      out.total = out.total + prior;
      out.terms.emplace_back("skinning", prior.detach());
    }
    if (options_.layer_weight > 0) {
      const auto prior = options_.layer_weight * surface_layer_spread(*avatar_);
      out.total = out.total + prior;
      out.terms.emplace_back("layer", prior.detach());
    }
    if (options_.opacity_weight > 0) {
      const auto prior = options_.opacity_weight * opacity_entropy(*avatar_);
      out.total = out.total + prior;
      out.terms.emplace_back("opacity", prior.detach());
    }
    const bool unseen = options_.alpha_entropy_weight > 0 || options_.rig_silhouette_weight > 0;
    if (unseen && step % options_.unseen_view_every == 0) {
      // The bones come detached: no pose correction learns from the unseen
      // view, so the Gaussians are posed again for it.
      const auto view = draw_unseen_view(posed_centre(posed.means), camera, box);
      const auto alpha = avatar_->render(bones.detach(), view, background_).alpha;
      // Sums over the training picture's pixel count, as the other losses; drawn
      // on one step in `every`, each prior counts `every` times there, so that
      // its weight is its mean per step whatever `every` is.
      const double scale = static_cast<double>(options_.unseen_view_every) / (camera.width * camera.height);
      if (options_.alpha_entropy_weight > 0) {
        const auto prior = options_.alpha_entropy_weight * scale * alpha_entropy_sum(alpha);
        out.total = out.total + prior;
        out.terms.emplace_back("alpha_entropy", prior.detach());
      }
      if (options_.rig_silhouette_weight > 0) {
        const auto coverage = posed_rig_coverage(character_, bones, view);
        const auto prior = options_.rig_silhouette_weight * scale * (alpha - coverage).abs().sum();
        out.total = out.total + prior;
        out.terms.emplace_back("rig_silhouette", prior.detach());
      }
    }
    if (corrections_ && !poses_frozen_) {
      const auto pose_loss = options_.pose_regularizer * corrections_->squared_size({frame_[i]});
      out.total = out.total + pose_loss;
      out.terms.emplace_back("pose", pose_loss.detach());
    }
    if (last_.offsets.defined() && options_.non_rigid_weight > 0) {
      const auto prior = options_.non_rigid_weight * (last_.offsets / size_).square().sum(1).mean();
      out.total = out.total + prior;
      out.terms.emplace_back("non_rigid", prior.detach());
    }
    const auto mse = ((last_.image.detach() - target).pow(2).sum() / (3 * pixels)).to(torch::kFloat64);
    out.metrics = {{"psnr", -10 * torch::log10(mse.clamp_min(1e-12))}};
    out.host_metrics = {{"gaussians", static_cast<double>(avatar_->size())}};
    out.throughput = {"pixels_per_s", static_cast<double>(cropped.width) * cropped.height};
    return out;
  }

  void after_step(int64_t step, torch::optim::Adam& adam) override {
    const auto& d = options_.density;
    const int64_t done = step + 1;
    const int64_t stop = static_cast<int64_t>(d.stop_fraction * static_cast<double>(options_.steps));
    if (done > stop) return;
    if (last_.means2d.grad().defined())
      statistics_.add(last_.means2d.grad(), last_.radii, last_width_, last_height_);
    last_ = GaussianRender{};
    if (done >= d.start && done % d.every == 0) {
      densify_and_prune(*avatar_, statistics_, adam, d, size_);
      statistics_.reset(avatar_->size());
    }
    if (d.opacity_reset_every > 0 && done % d.opacity_reset_every == 0) reset_opacities(*avatar_, adam, 0.01);
  }

  // The unseen view of the step (gaussians/unseen_view_prior.h): its camera
  // turned about the posed avatar's centre by an angle drawn within
  // +-unseen_view_degrees, cut to the step's box.
  PinholeCamera draw_unseen_view(const Eigen::Vector3d& centre, const PinholeCamera& camera,
                                 const std::array<int64_t, 4>& box) {
    const double max_radians = options_.unseen_view_degrees * M_PI / 180;
    const double radians = (2 * torch::rand({1}, torch::kFloat64).item<double>() - 1) * max_radians;
    return unseen_view(camera, radians, centre).cropped(box[0], box[1], box[2], box[3]);
  }

  // The learned pose corrections (null without refine_poses).
  PoseCorrections corrections() const { return corrections_; }
  // The learned appearance codes (null without appearance.dim).
  AppearanceCodes appearance_codes() const { return appearance_; }

  std::string progress_text(const nlohmann::json& values) const override {
    return fmt::format("loss {:.4f} psnr {:.1f} {:.0f} gaussians", values.at("loss").get<double>(),
                       values.at("psnr").get<double>(), values.at("gaussians").get<double>());
  }

 private:
  GaussianAvatar avatar_;
  bool poses_frozen_;
  const GaussianTrainOptions& options_;
  const ImageSplit& split_;
  std::vector<std::array<int64_t, 4>> boxes_;  // per image, the box it is rendered in
  std::array<double, 3> background_;
  double size_;
  Skeleton skeleton_;
  RiggedMesh character_;  // the rig silhouette prior draws its mesh
  std::vector<int64_t> frame_;            // per image: its pose's frame (frames_of_images)
  PoseCorrections corrections_{nullptr};  // with refine_poses
  AppearanceCodes appearance_{nullptr};   // with avatar.appearance.dim > 0
  DensityStatistics statistics_;
  GaussianRender last_;  // the step's render, read by after_step
  int64_t last_width_ = 0, last_height_ = 0;
};

}  // namespace

GaussianTrainSummary train_gaussian_avatar(const GaussianTrainOptions& requested) {
  requested.validate();
  FSKIN_CHECK(!requested.data_dir.empty() && !requested.out_dir.empty(),
              "gaussian avatar train: --data and --out are required");
  GaussianTrainOptions options = requested;
  const RunDirectory run(requested.out_dir);
  check_output_apart_from_input(run.path(), requested.data_dir, "avatar train");
  RunLock lock(run.path());
  const auto config_file = run_file(run.path());
  options.resume = false;
  if (fs::exists(config_file)) {
    FSKIN_CHECK(requested.resume,
                "{} already holds a Gaussian avatar run; pass --resume to continue it or use another --out", run.path());
    options = read_gaussian_run_config(config_file, run.path());
    options.steps = requested.steps;
    options.progress = requested.progress;
    options.stop = requested.stop;
    options.resume = true;
  }
  FSKIN_CHECK(!fs::exists(run.avatar_config_file()),
              "{} holds a volume avatar run (avatar.json); train the Gaussian avatar into another --out", run.path());
  const ImageDataset data(options.data_dir);
  const auto split = data.load_split("train");
  FSKIN_CHECK(split.size() > 0, "{}: the train split has no images", options.data_dir);
  create_output_directory(run.path());
  write_file_atomically(config_file, gaussian_run_document(options).dump(2) + "\n");
  save_canonical_character(data.character(), run.character_file());

  GaussianTrainSummary summary;
  // Pose refinement's passes before the run's own (gaussian_training.h): the
  // first, and with fitting a second and one more per further round, each in
  // a run directory of its own; each starts fresh Gaussians from the previous
  // pass's poses, fitted after every pass from the second on. They run to
  // their ends first, unless the run's own pass has begun (a resumed run).
  const bool fits = options.fits_training_poses();
  const int pose_passes =
      !options.refines_in_two_passes() ? 0 : fits ? 1 + static_cast<int>(options.pose_fit_rounds) : 1;
  const int passes = pose_passes + 1;
  const auto label = [passes](int pass) {
    return passes == 1 ? std::string("gaussian avatar train")
                       : fmt::format("gaussian avatar train, pass {} of {}{}", pass, passes,
                                     pass < passes ? " (poses)" : "");
  };
  PoseCorrections pose_pass_poses{nullptr};
  if (pose_passes > 0 && !(options.resume && !run.checkpoints().empty())) {
    // The fits' settings: test-time fitting's, with the run's steps.
    PoseFittingOptions fitting;
    fitting.steps = options.pose_fit_steps;
    const auto& character = data.character();
    const double size = character_size(character.mesh.vertices, "gaussian avatar train: canonical vertices");
    const auto frame_of = frames_of_images(split.bone_transforms);
    for (int pass = 1; pass <= pose_passes; ++pass) {
      const RunDirectory pose_pass(run.pose_pass_directory(pass));
      if (!options.resume && fs::exists(pose_pass.path())) fs::remove_all(pose_pass.path());  // a fresh run's
      create_output_directory(pose_pass.path());
      GaussianTrainOptions pass_options = options;
      pass_options.steps = pass == 1 ? options.pose_first_pass_steps : options.steps;
      if (pass > 1) pass_options.pose_learning_rate = options.pose_second_pass_learning_rate;
      torch::manual_seed(options.seed);
      GaussianAvatar pass_avatar(data.character(), options.avatar_options(), options.seed);
      // Passes after a fit keep the fitted poses as they are.
      GaussianTrainable pass_trainable(pass_avatar, pass_options, data, split, /*poses_frozen=*/pass >= 3);
      if (pose_pass_poses) pass_trainable.corrections()->assign(*pose_pass_poses);
      const auto result = Trainer(pose_pass, trainer_settings(pass_options, label(pass))).run(pass_trainable);
      if (pass == 1) {
        summary.pose_pass_first_step = result.first_step;
        summary.pose_pass_last_step = result.last_step;
      }
      summary.seconds += result.seconds;
      if (result.stopped) {
        summary.stopped = true;
        return summary;
      }
      pose_pass_poses = pass_trainable.corrections();
      const bool next_pass_begun = options.resume && pass < pose_passes &&
                                   !RunDirectory(run.pose_pass_directory(pass + 1)).checkpoints().empty();
      if (pass >= 2 && fits && !next_pass_begun) {
        const auto codes = pass_trainable.appearance_codes();
        if (!fit_gaussian_training_poses(*pass_avatar, split, frame_of, *pose_pass_poses,
                                         codes ? codes.get() : nullptr, data.background(), character.skeleton, size,
                                         options.mask_weight, fitting, options.progress, options.stop)) {
          summary.stopped = true;  // a resumed run fits again, from the pass's end
          return summary;
        }
        pose_pass_poses->center();  // the gauge training keeps (PoseCorrectionsImpl::center)
        ++summary.pose_fits;
      }
    }
  }

  GaussianTrainOptions last = options;
  if (pose_passes > 0) last.pose_learning_rate = options.pose_second_pass_learning_rate;
  last.resume = options.resume && !run.checkpoints().empty();  // none yet: the pass starts
  torch::manual_seed(options.seed);
  GaussianAvatar avatar(data.character(), options.avatar_options(), options.seed);
  // After fitting, the run's own pass keeps the fitted poses as they are.
  GaussianTrainable trainable(avatar, last, data, split, /*poses_frozen=*/fits);
  // A resumed last pass reads its poses from its checkpoint instead.
  if (pose_pass_poses) trainable.corrections()->assign(*pose_pass_poses);
  const auto result = Trainer(run, trainer_settings(last, label(passes))).run(trainable);

  summary.first_step = result.first_step;
  summary.last_step = result.last_step;
  summary.seconds += result.seconds;
  summary.stopped = result.stopped;
  summary.gaussians = avatar->size();
  if (!result.last_logged.is_null()) {
    summary.final_loss = result.last_logged.at("loss").get<double>();
    summary.final_psnr = result.last_logged.at("psnr").get<double>();
  }
  return summary;
}

TrainedGaussianAvatar TrainedGaussianAvatar::load(const std::string& run_dir) {
  const RunDirectory run(run_dir);
  const auto config_file = run_file(run_dir);
  FSKIN_CHECK(fs::exists(config_file),
              "{}: not a Gaussian avatar run (no {}; train one with `fskin avatar train --representation gaussians`)",
              run_dir, config_file);
  TrainedGaussianAvatar out;
  out.options = read_gaussian_run_config(config_file, run_dir);
  FSKIN_CHECK(!(out.options.refines_in_two_passes() && run.checkpoints().empty() &&
                fs::exists(run.pose_pass_directory(1))),
              "{}: the run stopped in a pass of pose refinement (in {}), before the avatar itself; "
              "`fskin avatar train --data {} --out {} --representation gaussians --resume` finishes it",
              run_dir, run.pose_pass_directory(1), out.options.data_dir, run_dir);
  const auto character = load_canonical_character(run.character_file());
  out.avatar = GaussianAvatar(character, out.options.avatar_options(), out.options.seed);
  if (out.options.refine_poses) {
    out.skeleton = character.skeleton;
    out.size = character_size(character.mesh.vertices, "gaussian avatar: canonical vertices");
  }
  out.step = load_model_checkpoint(
      run, CheckpointChoice{}, kGaussianArchiveKey, [&out, &run_dir](torch::serialize::InputArchive& archive) {
        out.avatar->load(archive);
        if (out.options.refine_poses) {
          auto poses = checkpoint_part(archive, kPoseCorrectionsKey, run_dir, "refines poses");
          out.corrections = PoseCorrections(PoseCorrectionsImpl::read(poses));
        }
        if (out.options.avatar.appearance.dim > 0) {
          auto codes = checkpoint_part(archive, kAppearanceCodesKey, run_dir, "learns appearance codes");
          out.appearance = AppearanceCodes(AppearanceCodesImpl::read(codes));
        }
      });
  out.avatar->eval();
  return out;
}

torch::Tensor TrainedGaussianAvatar::bones_for(const torch::Tensor& given) const {
  return corrections ? corrections->bones_for(given, skeleton, size) : given;
}

RefinedPoses refined_gaussian_poses(const std::string& run_dir) {
  const auto trained = TrainedGaussianAvatar::load(run_dir);
  FSKIN_CHECK(trained.corrections, "{}: the run does not refine poses (train with --refine-poses)", run_dir);
  return refined_poses(*trained.corrections, trained.skeleton, trained.size, trained.options.data_dir, run_dir);
}

torch::Tensor TrainedGaussianAvatar::appearance_for(const torch::Tensor& given) const {
  return appearance ? appearance->code_for(given) : torch::Tensor();
}

std::pair<torch::Tensor, torch::Tensor> TrainedGaussianAvatar::render(const torch::Tensor& bones,
                                                                      const PinholeCamera& camera,
                                                                      const std::array<double, 3>& background,
                                                                      const torch::Tensor& appearance) {
  torch::NoGradGuard no_grad;
  const auto rendered =
      avatar->render(bones.detach().to(torch::kCPU, torch::kFloat32), camera, background, appearance);
  return {rendered.image.clamp(0, 1), rendered.alpha};
}

}  // namespace fskin
