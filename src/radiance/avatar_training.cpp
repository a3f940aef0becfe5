#include "fskin/radiance/avatar_training.h"

#include <torch/torch.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/training/checkpoint.h"
#include "fskin/training/trainer.h"
#include "fskin/training/run_lock.h"
#include "fskin/util/atomic_file.h"
#include "fskin/util/free_cores.h"
#include "fskin/util/progress.h"
#include "fskin/version.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

nlohmann::json options_json(const AvatarTrainOptions& o) {
  const auto& a = o.avatar;
  const auto& e = a.field.encoding;
  return {
      {"format", "fskin-avatar-run"},
      {"fskin_version", FSKIN_VERSION},
      {"data_dir", fs::absolute(o.data_dir).string()},
      {"encoding",
       {{"levels", e.levels},
        {"features_per_level", e.features_per_level},
        {"log2_table_size", e.log2_table_size},
        {"base_resolution", e.base_resolution},
        {"per_level_scale", e.per_level_scale}}},
      {"hidden_dim", a.field.hidden_dim},
      {"hidden_layers", a.field.hidden_layers},
      {"skinning_grid_resolution", a.skinning_grid_resolution},
      {"canonical_grid_resolution", a.canonical_grid_resolution},
      {"posed_grid_resolution", a.posed_grid_resolution},
      {"samples_per_diagonal", a.samples_per_diagonal},
      {"start_bones", a.start_bones},
      {"occupancy_opacity", a.occupancy_opacity},
      {"steps", o.steps},
      {"rays_per_step", o.rays_per_step},
      {"images_per_step", o.images_per_step},
      {"mask_box_fraction", o.mask_box_fraction},
      {"learning_rate", o.learning_rate},
      {"decay_fraction", o.decay_fraction},
      {"decay_factor", o.decay_factor},
      {"huber_delta", o.huber_delta},
      {"opacity_weight", o.opacity_weight},
      {"background", o.background},
      {"occupancy_every", o.occupancy_every},
      {"occupancy_warmup", o.occupancy_warmup},
      {"checkpoint_every", o.checkpoint_every},
      {"log_every", o.log_every},
      {"seed", o.seed},
  };
}

// The options a run recorded in its avatar.json, validated: every failure
// names the file.
AvatarTrainOptions read_run_options(const std::string& path, const std::string& run_dir) {
  try {
    const auto j = nlohmann::json::parse(read_file(path));
    FSKIN_CHECK(j.at("format").get<std::string>() == "fskin-avatar-run", "{}: not an avatar run", path);
    AvatarTrainOptions o;
    auto& a = o.avatar;
    auto& e = a.field.encoding;
    const auto& enc = j.at("encoding");
    e.levels = enc.at("levels");
    e.features_per_level = enc.at("features_per_level");
    e.log2_table_size = enc.at("log2_table_size");
    e.base_resolution = enc.at("base_resolution");
    e.per_level_scale = enc.at("per_level_scale");
    a.field.hidden_dim = j.at("hidden_dim");
    a.field.hidden_layers = j.at("hidden_layers");
    a.skinning_grid_resolution = j.at("skinning_grid_resolution");
    a.canonical_grid_resolution = j.at("canonical_grid_resolution");
    a.posed_grid_resolution = j.at("posed_grid_resolution");
    a.samples_per_diagonal = j.at("samples_per_diagonal");
    a.start_bones = j.at("start_bones");
    a.occupancy_opacity = j.at("occupancy_opacity");
    o.data_dir = j.at("data_dir");
    o.steps = j.at("steps");
    o.rays_per_step = j.at("rays_per_step");
    o.images_per_step = j.at("images_per_step");
    o.mask_box_fraction = j.at("mask_box_fraction");
    o.learning_rate = j.at("learning_rate");
    o.decay_fraction = j.at("decay_fraction");
    o.decay_factor = j.at("decay_factor");
    o.huber_delta = j.at("huber_delta");
    o.opacity_weight = j.at("opacity_weight");
    o.background = j.at("background");
    o.occupancy_every = j.at("occupancy_every");
    o.occupancy_warmup = j.at("occupancy_warmup");
    o.checkpoint_every = j.at("checkpoint_every");
    o.log_every = j.at("log_every");
    o.seed = j.at("seed");
    o.out_dir = run_dir;
    o.validate();
    return o;
  } catch (const nlohmann::json::exception& e) {
    fail("{}: {}", path, e.what());
  } catch (const Error& e) {
    fail("{}: {}", path, e.what());
  }
}

std::string config_path(const std::string& run_dir) { return (fs::path(run_dir) / "avatar.json").string(); }

ArchiveWriter state_writer(Avatar& avatar, torch::optim::Optimizer& optimizer, int64_t step) {
  return [&avatar, &optimizer, step](torch::serialize::OutputArchive& archive) {
    torch::serialize::OutputArchive model, adam;
    avatar->save(model);
    optimizer.save(adam);
    archive.write("avatar", model);
    archive.write("optimizer", adam);
    archive.write("step", torch::tensor(step));
  };
}

ArchiveReader state_reader(Avatar& avatar, torch::optim::Optimizer* optimizer, int64_t& step) {
  return [&avatar, optimizer, &step](torch::serialize::InputArchive& archive) {
    torch::serialize::InputArchive model;
    archive.read("avatar", model);
    avatar->load(model);
    if (optimizer) {
      torch::serialize::InputArchive adam;
      archive.read("optimizer", adam);
      optimizer->load(adam);
    }
    torch::Tensor t;
    archive.read("step", t);
    step = t.item<int64_t>();
  };
}

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
  FSKIN_CHECK(occupancy_every >= 1 && occupancy_warmup >= 0 && checkpoint_every >= 1 && log_every >= 1,
              "avatar train: occupancy, checkpoint and log intervals must be >= 1");
}

AvatarTrainSummary train_avatar(const AvatarTrainOptions& requested) {
  requested.validate();
  AvatarTrainOptions options = requested;
  const std::string run_dir = requested.out_dir;
  check_output_apart_from_input(run_dir, requested.data_dir, "avatar train");
  const RunLock lock(run_dir);  // one writer per run, before the run is read or written
  const auto config_file = config_path(run_dir);
  if (fs::exists(config_file)) {
    FSKIN_CHECK(requested.resume, "{} already holds an avatar run; pass --resume to continue it or use another --out",
                run_dir);
    // The run's own settings; only the number of steps may change.
    options = read_run_options(config_file, run_dir);
    options.steps = requested.steps;
    options.progress = requested.progress;
    options.stop = requested.stop;
    options.resume = true;
  }
  const ImageDataset data(options.data_dir);
  const auto split = data.load_split("train");
  FSKIN_CHECK(split.size() > 0, "{}: the train split has no images", options.data_dir);
  create_output_directory(run_dir);
  write_file_atomically(config_file, options_json(options).dump(2) + "\n");
  data.character().save((fs::path(run_dir) / "canonical.npz").string());

  torch::manual_seed(options.seed);
  Avatar avatar(data.character(), options.avatar);
  torch::optim::Adam adam(avatar->parameters(), torch::optim::AdamOptions(options.learning_rate).eps(1e-15));
  int64_t step = 0;
  if (options.resume) load_latest_checkpoint(run_dir, state_reader(avatar, &adam, step));

  // Per image, its mask's box grown by 20 % of its size (ends exclusive).
  std::vector<std::array<int64_t, 4>> boxes;
  for (int64_t i = 0; i < split.size(); ++i) boxes.push_back(mask_box(split.masks[i], 0.2));
  const auto dataset_background = torch::tensor(
      {data.background()[0], data.background()[1], data.background()[2]}, torch::kFloat32);
  // Posed frames per distinct pose (the views of one pose share it), made
  // again after each occupancy update.
  std::vector<int64_t> frame_id(split.size());
  for (int64_t i = 0; i < split.size(); ++i) {
    frame_id[i] = i;
    for (int64_t j = 0; j < i; ++j) {
      if (frame_id[j] == j && torch::equal(split.bone_transforms[i], split.bone_transforms[j])) {
        frame_id[i] = j;
        break;
      }
    }
  }
  std::map<int64_t, std::pair<int64_t, PosedFrame>> frames;  // id -> (occupancy version, frame)
  int64_t occupancy_version = 0;
  const auto frame_of = [&](int64_t image) -> const PosedFrame& {
    auto& entry = frames[frame_id[image]];
    if (!entry.second.bones.defined() || entry.first != occupancy_version)
      entry = {occupancy_version, avatar->pose(split.bone_transforms[image])};
    return entry.second;
  };

  const auto log_file = (fs::path(run_dir) / "log.jsonl").string();
  // What a killed write left behind, and log lines past the checkpoint.
  remove_stale_temporaries(run_dir);
  if (options.resume) keep_log_through_step(log_file, step);
  else write_file_atomically(log_file, std::string());
  std::ofstream log(log_file, std::ios::app);
  FSKIN_CHECK(log.good(), "avatar train: cannot append to {}", log_file);
  AvatarTrainSummary summary;
  summary.first_step = step;
  const auto start = std::chrono::steady_clock::now();
  ProgressBar bar("avatar train", std::max<int64_t>(options.steps - step, 0), options.progress);
  const int64_t H = split.images.size(1), W = split.images.size(2);
  int64_t saved = step;
  double loss_sum = 0, psnr_sum = 0;
  int64_t logged = 0;
  while (step < options.steps) {
    if (options.stop && options.stop->requested()) {
      summary.stopped = true;
      break;
    }
    follow_free_cores();
    const auto step_start = std::chrono::steady_clock::now();
    // Seeded per step: a resumed run draws what an uninterrupted one would.
    torch::manual_seed(options.seed * 1000003 + static_cast<uint64_t>(step));
    if (step >= options.occupancy_warmup && step % options.occupancy_every == 0) {
      avatar->update_canonical_occupancy();
      ++occupancy_version;
    }
    const auto images = torch::randint(split.size(), {options.images_per_step}, torch::kInt64);
    std::vector<torch::Tensor> colors, opacities, targets, masks;
    int64_t samples = 0;
    for (int64_t k = 0; k < options.images_per_step; ++k) {
      const int64_t i = images[k].item<int64_t>();
      const int64_t n = options.rays_per_step / options.images_per_step + (k < options.rays_per_step % options.images_per_step);
      const int64_t in_box = static_cast<int64_t>(std::llround(options.mask_box_fraction * n));
      const auto& b = boxes[i];
      const auto u = torch::cat({torch::randint(b[0], b[2], {in_box}, torch::kInt64),
                                 torch::randint(0, W, {n - in_box}, torch::kInt64)});
      const auto v = torch::cat({torch::randint(b[1], b[3], {in_box}, torch::kInt64),
                                 torch::randint(0, H, {n - in_box}, torch::kInt64)});
      const auto flat = v * W + u;
      const auto rgb = split.images[i].reshape({-1, 3}).index_select(0, flat).to(torch::kFloat32) / 255;
      const auto mask = split.masks[i].reshape({-1}).index_select(0, flat).to(torch::kFloat32) / 255;
      torch::Tensor background;
      if (options.background == "random") background = torch::rand({n, 3});
      else if (options.background == "white") background = torch::ones({n, 3});
      else if (options.background == "black") background = torch::zeros({n, 3});
      else background = dataset_background.expand({n, 3});
      // The image is the subject over the dataset's background: re-composite it over this one.
      const auto target = rgb + (1 - mask).unsqueeze(1) * (background - dataset_background);
      const auto [origins, directions] = camera_rays(split.cameras[i], torch::stack({u, v}, 1).to(torch::kFloat32));
      const auto rendered = avatar->render_rays(frame_of(i), origins, directions, background, /*jitter=*/true);
      colors.push_back(rendered.color);
      opacities.push_back(rendered.opacity);
      targets.push_back(target);
      masks.push_back(mask);
      samples += rendered.samples;
    }
    const auto color = torch::cat(colors), opacity = torch::cat(opacities);
    const auto target = torch::cat(targets), mask = torch::cat(masks);
    // eq. 20 (Huber on colour) + eq. 21 (L1 on opacity against the mask).
    const auto colour_loss = torch::huber_loss(color, target, at::Reduction::Mean, options.huber_delta);
    const auto loss = colour_loss + options.opacity_weight * (opacity - mask).abs().mean();
    const double loss_value = loss.item<double>();  // one host read per step
    FSKIN_CHECK(std::isfinite(loss_value),
                "{}: the loss became {} at step {} (learning rate {:g}); training stopped and the last checkpoint "
                "(step {}) is kept: resume with a lower --lr",
                run_dir, loss_value, step + 1, options.learning_rate, saved);
    adam.zero_grad();
    if (loss.requires_grad()) {
      loss.backward();
      const double rate =
          options.learning_rate * cosine_decay_scale(step, options.steps, options.decay_fraction, options.decay_factor);
      for (auto& group : adam.param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(rate);
      adam.step();
    }
    ++step;
    const double mse = (color.detach() - target).pow(2).mean().item<double>();
    const double batch_psnr = -10 * std::log10(std::max(mse, 1e-12));
    loss_sum += loss_value;
    psnr_sum += batch_psnr;
    ++logged;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - step_start).count();
    if (step % options.log_every == 0 || step == options.steps) {
      const nlohmann::json line = {{"step", step},
                                   {"loss", loss_sum / logged},
                                   {"psnr", psnr_sum / logged},
                                   {"samples_per_ray", static_cast<double>(samples) / options.rays_per_step},
                                   {"canonical_occupied", avatar->canonical_grid().occupied_fraction()},
                                   {"seconds", seconds},
                                   {"threads", at::get_num_threads()}};
      log << line.dump() << "\n" << std::flush;
      summary.final_loss = loss_sum / logged;
      summary.final_psnr = psnr_sum / logged;
      loss_sum = psnr_sum = 0;
      logged = 0;
    }
    bar.advance(1, fmt::format("loss {:.4f} psnr {:.1f} {:.0f} samples/ray {:.2f} it/s", loss_value,
                               batch_psnr, static_cast<double>(samples) / options.rays_per_step, 1.0 / seconds));
    if (step % options.checkpoint_every == 0) {
      save_checkpoint(run_dir, step, state_writer(avatar, adam, step));
      saved = step;
    }
  }
  bar.finish();
  if (saved != step || !find_checkpoint(run_dir, CheckpointChoice{})) save_checkpoint(run_dir, step, state_writer(avatar, adam, step));
  summary.last_step = step;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

TrainedAvatar TrainedAvatar::load(const std::string& run_dir) {
  const auto config_file = config_path(run_dir);
  FSKIN_CHECK(fs::exists(config_file), "{}: not an avatar run (no avatar.json; train one with `fskin avatar train`)",
              run_dir);
  TrainedAvatar out;
  out.options = read_run_options(config_file, run_dir);
  const auto character = AvatarCharacter::load((fs::path(run_dir) / "canonical.npz").string());
  out.avatar = Avatar(character, out.options.avatar);
  const auto loaded = load_latest_checkpoint(run_dir, state_reader(out.avatar, nullptr, out.step));
  FSKIN_CHECK(loaded.has_value(), "{}: no intact checkpoint", run_dir);
  out.avatar->eval();
  return out;
}

}  // namespace fskin
