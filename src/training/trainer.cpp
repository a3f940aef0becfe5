#include "fskin/training/trainer.h"

#include <ATen/CPUGeneratorImpl.h>
#include <cstdio>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fskin/core/error.h"
#include "fskin/evaluation/evaluation.h"
#include "fskin/losses/bootstrap_losses.h"
#include "fskin/losses/canonical_sparsity.h"
#include "fskin/losses/skinning_prior.h"
#include "fskin/training/checkpoint.h"
#include "fskin/training/run_lock.h"
#include "fskin/util/atomic_file.h"
#include "fskin/util/free_cores.h"
#include "fskin/util/progress.h"

namespace fskin {

namespace fs = std::filesystem;

uint64_t step_seed(uint64_t seed, int64_t step) {
  // SplitMix64 finaliser of (seed, step): neighbouring steps get unrelated streams.
  uint64_t z = seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(step) + 0x632BE59BD9B4E019ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double learning_rate_scale(const TrainConfig& config, int64_t step) {
  if (step < config.warmup_steps) {
    const double t = static_cast<double>(step) / static_cast<double>(config.warmup_steps);
    return config.warmup_factor + (1.0 - config.warmup_factor) * t;
  }
  return cosine_decay_scale(step, config.steps, config.decay_fraction, config.decay_factor);
}

double cosine_decay_scale(int64_t step, int64_t steps, double decay_fraction, double decay_factor) {
  const double decay_steps = decay_fraction * static_cast<double>(steps);
  const double decay_start = static_cast<double>(steps) - decay_steps;
  if (decay_steps <= 0 || static_cast<double>(step) <= decay_start) return 1.0;
  const double t = std::min(1.0, (static_cast<double>(step) - decay_start) / decay_steps);
  return decay_factor + (1.0 - decay_factor) * 0.5 * (1.0 + std::cos(M_PI * t));
}

namespace {

std::string config_path(const std::string& run_dir) { return (fs::path(run_dir) / "config.json").string(); }
std::string log_path(const std::string& run_dir) { return (fs::path(run_dir) / "log.jsonl").string(); }
std::string validation_log_path(const std::string& run_dir) {
  return (fs::path(run_dir) / "validation.jsonl").string();
}
std::string best_json_path(const std::string& run_dir) { return (fs::path(run_dir) / "best.json").string(); }

ArchiveWriter state_writer(int64_t step, OccupancyModel& model, torch::optim::Optimizer& optimizer) {
  return [&model, &optimizer, step](torch::serialize::OutputArchive& archive) {
    torch::serialize::OutputArchive model_archive, optimizer_archive;
    model.save(model_archive);
    optimizer.save(optimizer_archive);
    archive.write("model", model_archive);
    archive.write("optimizer", optimizer_archive);
    archive.write("step", torch::tensor(step));
  };
}

void save_state(const std::string& run_dir, int64_t step, OccupancyModel& model,
                torch::optim::Optimizer& optimizer, int keep) {
  save_checkpoint(run_dir, step, state_writer(step, model, optimizer), keep);
}

// Reads the model (and the optimiser, when given) of one checkpoint archive; returns its step.
ArchiveReader state_reader(OccupancyModel& model, torch::optim::Optimizer* optimizer, int64_t& step) {
  return [&model, optimizer, &step](torch::serialize::InputArchive& archive) {
    torch::serialize::InputArchive model_archive;
    archive.read("model", model_archive);
    model.load(model_archive);
    if (optimizer) {
      torch::serialize::InputArchive optimizer_archive;
      archive.read("optimizer", optimizer_archive);
      try {
        optimizer->load(optimizer_archive);
      } catch (const c10::Error& e) {
        throw Error(fmt::format(
            "its optimizer state does not match this model's {} parameter groups (checkpoints written before "
            "the skinning network got its own learning rate have one group); it can still be evaluated, meshed "
            "and animated, but not resumed ({})",
            optimizer->param_groups().size(), e.what_without_backtrace()));
      }
    }
    torch::Tensor t;
    archive.read("step", t);
    step = t.item<int64_t>();
  };
}

std::optional<int64_t> load_state(const std::string& run_dir, OccupancyModel& model,
                                  torch::optim::Optimizer* optimizer, const CheckpointChoice& choice = {}) {
  int64_t step = 0;
  if (choice.kind == CheckpointChoice::Kind::Latest) {
    if (!load_latest_checkpoint(run_dir, state_reader(model, optimizer, step))) return std::nullopt;
    return step;
  }
  load_checkpoint(*find_checkpoint(run_dir, choice), state_reader(model, optimizer, step));
  return step;
}

// Every parameter in exactly one optimiser group: a model that forgets one
// would silently not train it.
void check_parameter_groups(OccupancyModel& model, const std::vector<OccupancyModel::ParameterGroup>& groups) {
  size_t grouped = 0;
  for (const auto& group : groups) grouped += group.parameters.size();
  const size_t all = model.parameters().size();
  FSKIN_CHECK(grouped == all, "train: the model's parameter groups hold {} of its {} parameters", grouped, all);
}

struct BestScore {
  int64_t step = -1;
  double iou_bbox = 0, iou_surf = 0;
};

std::optional<BestScore> read_best(const std::string& run_dir) {
  const auto path = best_json_path(run_dir);
  if (!fs::exists(path) || !fs::exists(best_checkpoint_path(run_dir))) return std::nullopt;
  try {
    const auto j = nlohmann::json::parse(read_file(path));
    return BestScore{j.at("step").get<int64_t>(), j.at("iou_bbox").get<double>(), j.at("iou_surf").get<double>()};
  } catch (const nlohmann::json::exception& e) {
    fail("{}: malformed ({})", path, e.what());
  }
}

// Adam's moments follow the parameters: the state is read on the host and the
// model moved to the training device afterwards.
void move_optimizer_state(torch::optim::Adam& adam, const torch::Device& device) {
  for (auto& entry : adam.state()) {
    auto& state = static_cast<torch::optim::AdamParamState&>(*entry.second);
    state.exp_avg(state.exp_avg().to(device));
    state.exp_avg_sq(state.exp_avg_sq().to(device));
    if (state.max_exp_avg_sq().defined()) state.max_exp_avg_sq(state.max_exp_avg_sq().to(device));
  }
}

OccupancyBatch to_device(OccupancyBatch batch, const torch::Device& device) {
  return {batch.points.to(device), batch.occupancy.to(device), batch.bone_transforms.to(device),
          batch.pose.to(device)};
}

}  // namespace

TrainResult train(const TrainConfig& config, const BatchSource& source, const TrainOptions& options) {
  config.validate();
  FSKIN_CHECK(!options.run_dir.empty(), "train: no run directory given");
  FSKIN_CHECK(source.num_frames() > 0, "train: the training data has no frames");
  const RunLock lock(options.run_dir);  // one writer per run, before anything is written
  write_file_atomically(config_path(options.run_dir), config.to_json());

  torch::manual_seed(config.seed);
  // The bootstrap losses and the skinning prior use the bone segments that run
  // inside the body, or all of them (config.bootstrap_bones).
  CanonicalSkeleton skeleton = source.skeleton();
  if (config.bootstrap_bones == "all") skeleton.segment_in_body.clear();
  const auto described = model_options(config, skeleton);
  const double outside = fraction_outside_grid(described, skeleton);
  if (outside > 0)
    std::fprintf(stderr,
                 "fskin: warning: %.1f %% of the canonical body lies outside the skinning grid box and gets no "
                 "skinning weights (grid_resolution=%lld%s)\n",
                 100 * outside, static_cast<long long>(config.grid_resolution),
                 config.grid_resolution == 0 ? ": the papers' person layout; the default fits any character" : "");
  const auto model_ptr = make_model(described);
  OccupancyModel& model = *model_ptr;
  model.train(true);
  std::vector<torch::optim::OptimizerParamGroup> groups;
  std::vector<double> base_rates;  // per group, before warm-up
  const auto parameter_groups = model.parameter_groups(config.learning_rate);
  check_parameter_groups(model, parameter_groups);
  for (auto& group : parameter_groups) {
    groups.emplace_back(group.parameters, std::make_unique<torch::optim::AdamOptions>(group.learning_rate));
    base_rates.push_back(group.learning_rate);
  }
  torch::optim::Adam adam(std::move(groups), torch::optim::AdamOptions(config.learning_rate));

  int64_t step = 0;
  double result_prior_loss = 0;
  // A run killed before its first checkpoint has nothing to resume: it starts
  // again from step 0, which is what an uninterrupted run would have done.
  // Checkpoints that exist but fail their CRC stay an error.
  const bool resuming = options.resume && !list_checkpoints(options.run_dir).empty();
  if (options.resume && !resuming)
    std::fprintf(stderr, "fskin: %s has no checkpoint yet: training from step 0\n", options.run_dir.c_str());
  if (resuming) {
    const auto loaded = load_state(options.run_dir, model, &adam);
    FSKIN_CHECK(loaded.has_value(), "train --resume: no intact checkpoint in {}", options.run_dir);
    step = *loaded;
  }
  model.to(options.device);
  move_optimizer_state(adam, options.device);
  if (!resuming && config.skinning_prior_steps > 0 && model.canonical_skinning_field() != nullptr) {
    result_prior_loss = fit_skinning_prior(*model.canonical_skinning_field(), skeleton, config.skinning_prior_steps,
                                           config.learning_rate, step_seed(config.seed, -1));
  }
  const bool validating = config.validate_every > 0;
  FSKIN_CHECK(!validating || (options.validation != nullptr && !options.validation->empty()),
              "train: validate_every = {} but no validation frames were given", config.validate_every);
  const std::string log_file = log_path(options.run_dir), validation_file = validation_log_path(options.run_dir);
  std::optional<BestScore> best;
  remove_stale_temporaries(options.run_dir);
  if (resuming) {
    keep_log_through_step(log_file, step);
    if (fs::exists(validation_file)) keep_log_through_step(validation_file, step);
    best = read_best(options.run_dir);
  } else {
    write_file_atomically(log_file, std::string());
    fs::remove(validation_file);
    fs::remove(best_json_path(options.run_dir));
    fs::remove(best_checkpoint_path(options.run_dir));
  }
  std::ofstream log(log_file, std::ios::app);
  FSKIN_CHECK(log.good(), "train: cannot append to {}", log_file);

  TrainResult result;
  result.first_step = step;
  result.skinning_prior_loss = result_prior_loss;
  const int64_t bootstrap_steps = config.bootstrap_steps(source.num_frames());
  const bool use_sparsity = config.canonical_sparsity_weight > 0 && model.has_canonical_shape();
  const Box canonical_box = use_sparsity ? canonical_bounds(skeleton) : Box{};
  const auto start = std::chrono::steady_clock::now();
  ProgressBar bar("train", std::max<int64_t>(config.steps - step, 0), options.progress);
  int64_t saved_step = resuming ? step : -1;
  while (step < config.steps) {
    if (options.stop && options.stop->requested()) {
      result.stopped = true;
      break;
    }
    follow_free_cores();
    const auto step_start = std::chrono::steady_clock::now();
    const uint64_t seed = step_seed(config.seed, step);
    // Models may draw from the default generator during a step (the PINs'
    // bone dropout); seeding it per step keeps --resume bit-for-bit.
    torch::manual_seed(seed ^ 0x2545f491u);
    const auto batch = to_device(
        source.batch(config.frames_per_batch, config.surface_points, config.uniform_points, seed), options.device);
    auto prediction = model.predict(batch.points, batch.bone_transforms, batch.pose, Aggregation::Soft);
    const auto bce = torch::binary_cross_entropy_with_logits(prediction.logits, batch.occupancy);
    auto loss = bce;
    // The logged terms stay on the device until one read after the step.
    auto bootstrap = torch::zeros({}, bce.options());
    if (step < bootstrap_steps) {
      auto generator = at::make_generator<at::CPUGeneratorImpl>(seed);
      const BootstrapInputs inputs{&skeleton, sample_bone_points(skeleton, config.bone_points_per_bone, generator),
                                   batch.pose, config.joint_weight_loss_weight};
      const auto extra = bootstrap_loss(model, inputs);
      if (extra.defined()) {
        bootstrap = extra.detach();
        loss = loss + extra;
      }
    }
    auto sparsity = torch::zeros({}, bce.options());
    if (use_sparsity) {
      auto generator = at::make_generator<at::CPUGeneratorImpl>(seed ^ 0x5bd1e995u);  // not the bootstrap's stream
      const auto prior = config.canonical_sparsity_weight *
                         canonical_sparsity_loss(model, canonical_box, batch.pose, config.canonical_sparsity_points,
                                                 generator);
      sparsity = prior.detach();
      loss = loss + prior;
    }
    adam.zero_grad();
    loss.backward();
    if (config.grad_clip > 0) torch::nn::utils::clip_grad_norm_(model.parameters(), config.grad_clip);
    const double rate_scale = learning_rate_scale(config, step);
    for (size_t g = 0; g < adam.param_groups().size(); ++g) {
      static_cast<torch::optim::AdamOptions&>(adam.param_groups()[g].options()).lr(base_rates[g] * rate_scale);
    }
    adam.step();
    ++step;

    // One host read per step for everything the log shows.
    const auto predicted = prediction.logits.detach() > 0, truth = batch.occupancy > 0.5;
    const auto logged = torch::stack({bce.detach().to(torch::kFloat64), bootstrap.to(torch::kFloat64),
                                      sparsity.to(torch::kFloat64), (predicted & truth).sum().to(torch::kFloat64),
                                      (predicted | truth).sum().to(torch::kFloat64)})
                            .cpu();
    const auto* values = logged.data_ptr<double>();
    const double bce_value = values[0], bootstrap_value = values[1], sparsity_value = values[2];
    const double iou = values[4] == 0 ? 1.0 : values[3] / values[4];  // iou.h's convention
    FSKIN_CHECK(std::isfinite(bce_value + bootstrap_value + sparsity_value),
                "{}: the loss became {} at step {} (learning rate {:g}); training stopped and the last checkpoint{} is "
                "kept: lower learning_rate (--set learning_rate=...) and resume",
                options.run_dir, bce_value + bootstrap_value + sparsity_value, step, config.learning_rate,
                saved_step >= 0 ? fmt::format(" (step {})", saved_step) : std::string(" (none yet)"));
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - step_start).count();
    if (step == result.first_step + 1) result.first_loss = bce_value;
    result.last_loss = bce_value;
    nlohmann::json line = {{"step", step},
                           {"loss", bce_value + bootstrap_value + sparsity_value},
                           {"bce", bce_value},
                           {"bootstrap", bootstrap_value},
                           {"sparsity", sparsity_value},
                           {"batch_iou", iou},
                           {"lr", config.learning_rate * rate_scale},
                           {"seconds", seconds},
                           {"threads", at::get_num_threads()},
                           {"points_per_s", static_cast<double>(batch.points.size(0) * batch.points.size(1)) / seconds},
                           {"deformer_s", prediction.deformer_seconds},
                           {"valid_per_point", prediction.deformer.mean_valid}};
    log << line.dump() << "\n" << std::flush;
    bar.advance(1, fmt::format("loss {:.4f} iou {:.3f} {:.2f} it/s", bce_value, iou, 1.0 / seconds));
    if (step % config.checkpoint_every == 0) {
      save_state(options.run_dir, step, model, adam, static_cast<int>(config.keep_checkpoints));
      saved_step = step;
    }
    if (validating && step % config.validate_every == 0) {
      const auto scores = evaluate(model, *options.validation, "val", config.eval_chunk_points);
      model.train(true);
      const nlohmann::json row = {{"step", step}, {"iou_bbox", scores.mean_iou_bbox}, {"iou_surf", scores.mean_iou_surf}};
      std::ofstream(validation_file, std::ios::app) << row.dump() << "\n" << std::flush;
      if (!best || scores.mean_iou_surf > best->iou_surf) {
        best = BestScore{step, scores.mean_iou_bbox, scores.mean_iou_surf};
        // The checkpoint first, then best.json naming it: a kill in between
        // leaves an older best.json whose score the new file only beats.
        write_checkpoint_file(best_checkpoint_path(options.run_dir), state_writer(step, model, adam));
        write_file_atomically(best_json_path(options.run_dir), nlohmann::json{{"step", best->step},
                                                                              {"iou_bbox", best->iou_bbox},
                                                                              {"iou_surf", best->iou_surf},
                                                                              {"frames", options.validation->size()}}
                                                                   .dump(2) + "\n");
      }
    }
  }
  bar.finish();
  if (saved_step != step) save_state(options.run_dir, step, model, adam, static_cast<int>(config.keep_checkpoints));
  result.last_step = step;
  if (best) {
    result.best_step = best->step;
    result.best_iou_surf = best->iou_surf;
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::shared_ptr<OccupancyModel> load_trained_model(const std::string& run_dir, const CanonicalSkeleton& skeleton,
                                                   int64_t* step, const CheckpointChoice& choice) {
  const auto config = TrainConfig::load_run(config_path(run_dir));
  auto model = make_model(config, skeleton);
  const auto loaded = load_state(run_dir, *model, nullptr, choice);
  FSKIN_CHECK(loaded.has_value(), "{}: no intact checkpoint (was the run trained?)", run_dir);
  if (step) *step = *loaded;
  model->train(false);
  return model;
}

}  // namespace fskin
