#include "fskin/radiance/avatar_training.h"

#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/radiance/avatar_character.h"
#include "fskin/radiance/avatar_config.h"
#include "fskin/radiance/image_rays.h"
#include "fskin/engine/checkpoint.h"
#include "fskin/engine/run_directory.h"
#include "fskin/engine/run_lock.h"
#include "fskin/engine/trainer.h"
#include "fskin/geometry/character_size.h"
#include "fskin/util/atomic_file.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

}  // namespace

void AvatarTrainOptions::validate() const {
  avatar.validate();
  FSKIN_CHECK(!data_dir.empty() && !out_dir.empty(), "avatar train: --data and --out are required");
  FSKIN_CHECK(steps >= 0, "avatar train: steps must be >= 0, got {}", steps);
  FSKIN_CHECK(rays_per_step >= 1, "avatar train: rays per step must be >= 1, got {}", rays_per_step);
  FSKIN_CHECK(images_per_step >= 1 && images_per_step <= rays_per_step,
              "avatar train: images per step must be within 1..rays per step, got {}", images_per_step);
  FSKIN_CHECK(mask_box_fraction >= 0 && mask_box_fraction <= 1,
              "avatar train: mask box fraction must be within [0, 1], got {}", mask_box_fraction);
  FSKIN_CHECK(decay_fraction >= 0 && decay_fraction <= 1 && decay_factor > 0 && decay_factor <= 1,
              "avatar train: decay fraction must be within [0, 1] and decay factor within (0, 1]");
  FSKIN_CHECK(learning_rate > 0 && learning_rate <= 1, "avatar train: the learning rate {} must be in (0, 1]",
              learning_rate);
  FSKIN_CHECK(std::isfinite(huber_delta) && huber_delta > 0 && std::isfinite(opacity_weight) && opacity_weight >= 0,
              "avatar train: the Huber delta must be > 0 and the opacity weight >= 0 (finite)");
  FSKIN_CHECK(background == "dataset" || background == "white" || background == "black" || background == "random",
              "avatar train: background must be dataset, white, black or random, got '{}'", background);
  FSKIN_CHECK(pose_learning_rate > 0 && pose_learning_rate <= 1,
              "avatar train: the pose learning rate {} must be in (0, 1]", pose_learning_rate);
  FSKIN_CHECK(std::isfinite(pose_regularizer) && pose_regularizer >= 0,
              "avatar train: the pose regulariser must be >= 0 (finite), got {}", pose_regularizer);
  FSKIN_CHECK(std::isfinite(skinning_prior) && skinning_prior >= 0,
              "avatar train: the skinning prior must be >= 0 (finite), got {}", skinning_prior);
  FSKIN_CHECK(occupancy_every >= 1 && occupancy_warmup >= 0 && checkpoint_every >= 1 && log_every >= 1,
              "avatar train: occupancy, checkpoint and log intervals must be >= 1");
}

namespace {

constexpr const char* kAvatarArchiveKey = "avatar";
constexpr const char* kPoseCorrectionsKey = "pose_corrections";  // inside the avatar's archive
constexpr const char* kAppearanceCodesKey = "appearance_codes";  // inside the avatar's archive

// Per image, its mask's box grown by 20 % of its size (ends exclusive).
std::vector<std::array<int64_t, 4>> mask_boxes(const ImageSplit& split) {
  std::vector<std::array<int64_t, 4>> boxes;
  for (int64_t i = 0; i < split.size(); ++i) boxes.push_back(mask_box(split.masks[i], 0.2));
  return boxes;
}

// The avatar as the engine trains it (engine/trainable.h): per step, rays
// from `images_per_step` training images, mostly inside their mask boxes;
// Huber on colour (eq. 20) + L1 on opacity against the mask (eq. 21); the
// canonical occupancy grid refreshed every occupancy_every steps.
class AvatarTrainable : public Trainable {
 public:
  AvatarTrainable(Avatar avatar, const AvatarTrainOptions& options, const ImageDataset& data, const ImageSplit& split)
      : avatar_(std::move(avatar)),
        options_(options),
        split_(split),
        boxes_(mask_boxes(split)),
        dataset_background_(torch::tensor({data.background()[0], data.background()[1], data.background()[2]},
                                          torch::kFloat32)),
        frame_(frames_of_images(split.bone_transforms)),
        skeleton_(data.character().skeleton),
        size_(character_size(data.character().mesh.vertices, "avatar train: canonical vertices")) {
    // The views of one pose share its posed frame (and its pose correction).
    const auto frame_bones = frame_bone_transforms(split.bone_transforms, frame_);
    if (options.refine_poses) corrections_ = PoseCorrections(frame_bones);
    if (options.avatar.field.appearance_dim > 0)
      appearance_ = AppearanceCodes(frame_bones, options.avatar.field.appearance_dim);
  }

  std::vector<OptimizerGroup> optimizer_groups() override {
    std::vector<OptimizerGroup> groups{{avatar_->parameters(), options_.learning_rate}};
    if (corrections_) groups.push_back({corrections_->parameters(), options_.pose_learning_rate});
    if (appearance_) groups.push_back({appearance_->parameters(), options_.learning_rate});
    return groups;
  }
  std::vector<torch::Tensor> parameters() override {
    auto all = avatar_->parameters();
    if (corrections_) {
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
    archive.write(kAvatarArchiveKey, model);
  }
  void load(torch::serialize::InputArchive& archive) override {
    torch::serialize::InputArchive model;
    archive.read(kAvatarArchiveKey, model);
    avatar_->load(model);
    {
      torch::NoGradGuard no_grad;  // each step sets its own grid with a graph
      avatar_->refresh_skinning();
    }
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
    FSKIN_CHECK(device.is_cpu(), "avatar train: avatars train on the CPU only (asked for {})", device.str());
  }

  StepLosses step_losses(int64_t step, uint64_t seed, const Shard& shard) override {
    const int64_t image_count = options_.images_per_step;
    FSKIN_CHECK(shard.count == 1 || (image_count % shard.count == 0 && options_.rays_per_step % image_count == 0),
                "avatar train: with {} ranks, images per step ({}) must be a multiple of the number of ranks and rays "
                "per step ({}) a multiple of images per step",
                shard.count, image_count, options_.rays_per_step);
    if (corrections_) {
      corrections_->forget_gradients();
      corrections_->center();
    }
    if (appearance_) {
      appearance_->forget_gradients();
      appearance_->center();
    }
    if (step >= options_.occupancy_warmup && step % options_.occupancy_every == 0) {
      avatar_->update_canonical_occupancy();
      ++occupancy_version_;
    }
    // Learned skinning: this step's grid, with its graph (avatar.h).
    avatar_->refresh_skinning();
    const auto images = torch::randint(split_.size(), {image_count}, torch::kInt64);
    std::vector<torch::Tensor> colors, opacities, targets, masks;
    std::vector<int64_t> refined_frames;
    int64_t samples = 0;
    const int64_t share = image_count / shard.count;
    for (int64_t k = shard.index * share; k < (shard.index + 1) * share; ++k) {
      // Each image's rays, backgrounds and jitter from (step, k) alone: a
      // rank renders its images as one process would.
      torch::manual_seed(step_seed(seed, k));
      const int64_t i = images[k].item<int64_t>();
      const int64_t n = options_.rays_per_step / image_count + (k < options_.rays_per_step % image_count);
      const auto rays = sample_image_rays(split_, i, boxes_[i], n, options_.mask_box_fraction, options_.background,
                                          dataset_background_);
      PosedFrame frame = frame_of(i);
      if (corrections_) {
        // The cached frame's grids came from the corrections of its last
        // refresh; the rays see this step's (differentiable) bones.
        frame.bones = corrections_->apply(frame_[i], skeleton_, size_);
        refined_frames.push_back(frame_[i]);
      }
      if (appearance_) frame.appearance = appearance_->code(frame_[i]);
      const auto rendered = avatar_->render_rays(frame, rays.origins, rays.directions, rays.background,
                                                 /*jitter=*/true);
      colors.push_back(rendered.color);
      opacities.push_back(rendered.opacity);
      targets.push_back(rays.target);
      masks.push_back(rays.mask);
      samples += rendered.samples;
    }
    const auto color = torch::cat(colors), opacity = torch::cat(opacities);
    const auto target = torch::cat(targets), mask = torch::cat(masks);
    // eq. 20 (Huber on colour) + eq. 21 (L1 on opacity against the mask),
    // means over this rank's rays (an equal share of the step's).
    const auto loss = avatar_ray_loss(color, opacity, target, mask, options_.huber_delta, options_.opacity_weight);
    const auto mse = (color.detach() - target).pow(2).mean().to(torch::kFloat64);
    StepLosses out;
    out.total = loss.total();
    out.terms = {{"colour", loss.colour.detach()}, {"opacity", loss.opacity.detach()}};
    if (corrections_) {
      const auto pose_loss = options_.pose_regularizer * corrections_->squared_size(refined_frames);
      out.total = out.total + pose_loss;
      out.terms.push_back({"pose", pose_loss.detach()});
    }
    if (avatar_->learns_skinning()) {
      const auto prior = options_.skinning_prior * avatar_->skinning_prior();
      out.total = out.total + prior;
      out.terms.push_back({"skinning", prior.detach()});
    }
    out.metrics = {{"psnr", -10 * torch::log10(mse.clamp_min(1e-12))}};
    out.host_metrics = {{"samples_per_ray", static_cast<double>(samples) / options_.rays_per_step},
                        {"canonical_occupied", avatar_->canonical_grid().occupied_fraction()}};
    out.throughput = {"rays_per_s", static_cast<double>(options_.rays_per_step) / shard.count};
    return out;
  }

  std::string progress_text(const nlohmann::json& values) const override {
    return fmt::format("loss {:.4f} psnr {:.1f} {:.0f} samples/ray", values.at("loss").get<double>(),
                       values.at("psnr").get<double>(), values.at("samples_per_ray").get<double>());
  }

 private:
  // The posed frame of an image's pose, made again after each occupancy update.
  const PosedFrame& frame_of(int64_t image) {
    auto& entry = frames_[frame_[image]];
    if (!entry.second.bones.defined() || entry.first != occupancy_version_) {
      const auto bones =
          corrections_ ? corrections_->apply(frame_[image], skeleton_, size_).detach() : split_.bone_transforms[image];
      entry = {occupancy_version_, avatar_->pose(bones)};
    }
    return entry.second;
  }

  Avatar avatar_;
  const AvatarTrainOptions& options_;
  const ImageSplit& split_;
  std::vector<std::array<int64_t, 4>> boxes_;
  torch::Tensor dataset_background_;
  std::vector<int64_t> frame_;  // per image: its frame (frames_of_images)
  Skeleton skeleton_;
  double size_;
  PoseCorrections corrections_{nullptr};  // with refine_poses
  AppearanceCodes appearance_{nullptr};   // with appearance_dim > 0
  std::map<int64_t, std::pair<int64_t, PosedFrame>> frames_;  // frame -> (occupancy version, posed frame)
  int64_t occupancy_version_ = 0;
};

}  // namespace

AvatarTrainSummary train_avatar(const AvatarTrainOptions& requested) {
  requested.validate();
  AvatarTrainOptions options = requested;
  const RunDirectory run(requested.out_dir);
  check_output_apart_from_input(run.path(), requested.data_dir, "avatar train");
  DataParallel* const parallel = requested.parallel;
  const bool writer = parallel == nullptr || parallel->rank() == 0;
  // One writer per run (rank 0 of several), locked before the run is read or written.
  std::optional<RunLock> lock;
  if (writer) lock.emplace(run.path());
  const auto config_file = run.avatar_config_file();
  options.resume = false;
  if (fs::exists(config_file)) {
    FSKIN_CHECK(requested.resume, "{} already holds an avatar run; pass --resume to continue it or use another --out",
                run.path());
    // The run's own settings; only the number of steps may change.
    options = read_avatar_run_config(config_file, run.path());
    options.steps = requested.steps;
    options.progress = requested.progress;
    options.stop = requested.stop;
    options.resume = true;
  }
  const ImageDataset data(options.data_dir);
  const auto split = data.load_split("train");
  FSKIN_CHECK(split.size() > 0, "{}: the train split has no images", options.data_dir);
  // Every rank has read whether the run exists before rank 0 writes it.
  if (parallel) parallel->barrier();
  if (writer) {
    create_output_directory(run.path());
    write_file_atomically(config_file, avatar_run_document(options).dump(2) + "\n");
    save_canonical_character(data.character(), run.character_file());
  }

  torch::manual_seed(options.seed);
  AvatarTrainable trainable(Avatar(data.character(), options.avatar), options, data, split);
  TrainerSettings settings;
  settings.steps = options.steps;
  settings.seed = options.seed;
  settings.schedule.decay_fraction = options.decay_fraction;
  settings.schedule.decay_factor = options.decay_factor;
  settings.learning_rate = options.learning_rate;
  settings.adam_eps = 1e-15;  // the hash table's rarely-touched entries (instant-ngp)
  settings.log_every = options.log_every;
  settings.checkpoint_every = options.checkpoint_every;
  settings.resume = options.resume;
  settings.progress = options.progress;
  settings.progress_label = "avatar train";
  settings.learning_rate_hint = "lower --lr";
  settings.stop = options.stop;
  settings.parallel = parallel;
  const auto result = Trainer(run, settings).run(trainable);

  AvatarTrainSummary summary;
  summary.first_step = result.first_step;
  summary.last_step = result.last_step;
  summary.seconds = result.seconds;
  summary.stopped = result.stopped;
  if (!result.last_logged.is_null()) {
    summary.final_loss = result.last_logged.at("loss").get<double>();
    summary.final_psnr = result.last_logged.at("psnr").get<double>();
  }
  return summary;
}

TrainedAvatar TrainedAvatar::load(const std::string& run_dir) {
  const RunDirectory run(run_dir);
  const auto config_file = run.avatar_config_file();
  FSKIN_CHECK(fs::exists(config_file), "{}: not an avatar run (no avatar.json; train one with `fskin avatar train`)",
              run_dir);
  TrainedAvatar out;
  out.options = read_avatar_run_config(config_file, run_dir);
  const auto character = load_canonical_character(run.character_file());
  out.avatar = Avatar(character, out.options.avatar);
  if (out.options.refine_poses) {
    out.skeleton = character.skeleton;
    out.size = character_size(character.mesh.vertices, "avatar: canonical vertices");
  }
  out.step = load_model_checkpoint(run, CheckpointChoice{}, kAvatarArchiveKey,
                                   [&out, &run_dir](torch::serialize::InputArchive& archive) {
                                     out.avatar->load(archive);
                                     if (out.options.avatar.field.appearance_dim > 0) {
                                       auto codes = checkpoint_part(archive, kAppearanceCodesKey, run_dir,
                                                                    "learns appearance codes");
                                       out.appearance = AppearanceCodes(AppearanceCodesImpl::read(codes));
                                     }
                                     if (out.options.refine_poses) {
                                       auto poses = checkpoint_part(archive, kPoseCorrectionsKey, run_dir,
                                                                    "refines poses");
                                       out.corrections = PoseCorrections(PoseCorrectionsImpl::read(poses));
                                     }
                                   });
  out.avatar->eval();
  {
    torch::NoGradGuard no_grad;  // the loaded grid, without a graph (renders and pose fitting)
    out.avatar->refresh_skinning();
  }
  return out;
}

torch::Tensor TrainedAvatar::bones_for(const torch::Tensor& given) const {
  return corrections ? corrections->bones_for(given, skeleton, size) : given;
}

torch::Tensor TrainedAvatar::appearance_for(const torch::Tensor& given) const {
  return appearance ? appearance->code_for(given) : torch::Tensor();
}

std::pair<torch::Tensor, torch::Tensor> TrainedAvatar::render(const torch::Tensor& bones, const PinholeCamera& camera,
                                                              const std::array<double, 3>& background,
                                                              const torch::Tensor& appearance_code) {
  auto frame = avatar->pose(bones.detach().to(torch::kCPU, torch::kFloat32));
  frame.appearance = appearance_code;
  return avatar->render_image(frame, camera, background);
}

}  // namespace fskin
