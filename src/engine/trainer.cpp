#include "fskin/engine/trainer.h"

#include <fmt/format.h>
#include <torch/torch.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>

#include "fskin/core/error.h"
#include "fskin/engine/checkpoint.h"
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

double LearningRateSchedule::scale(int64_t step, int64_t steps) const {
  if (step < warmup_steps) {
    const double t = static_cast<double>(step) / static_cast<double>(warmup_steps);
    return warmup_factor + (1.0 - warmup_factor) * t;
  }
  const double decay_steps = decay_fraction * static_cast<double>(steps);
  const double decay_start = static_cast<double>(steps) - decay_steps;
  if (decay_steps <= 0 || static_cast<double>(step) <= decay_start) return 1.0;
  const double t = std::min(1.0, (static_cast<double>(step) - decay_start) / decay_steps);
  return decay_factor + (1.0 - decay_factor) * 0.5 * (1.0 + std::cos(M_PI * t));
}

int64_t load_model_checkpoint(const RunDirectory& run, const CheckpointChoice& choice, const std::string& key,
                              const std::function<void(torch::serialize::InputArchive&)>& load_model) {
  int64_t step = 0;
  const auto read = [&](torch::serialize::InputArchive& archive) {
    torch::serialize::InputArchive model;
    archive.read(key, model);
    load_model(model);
    torch::Tensor t;
    archive.read("step", t);
    step = t.item<int64_t>();
  };
  if (choice.kind == CheckpointChoice::Kind::Latest) {
    FSKIN_CHECK(load_latest_checkpoint(run.path(), read).has_value(), "{}: no intact checkpoint (was the run trained?)",
                run.path());
  } else {
    load_checkpoint(*find_checkpoint(run.path(), choice), read);
  }
  return step;
}

namespace {

constexpr const char* kOptimizerKey = "optimizer";

ArchiveWriter state_writer(Trainable& trainable, torch::optim::Optimizer& optimizer, int64_t step) {
  return [&trainable, &optimizer, step](torch::serialize::OutputArchive& archive) {
    trainable.save(archive);
    torch::serialize::OutputArchive optimizer_archive;
    optimizer.save(optimizer_archive);
    archive.write(kOptimizerKey, optimizer_archive);
    archive.write("step", torch::tensor(step));
  };
}

ArchiveReader state_reader(Trainable& trainable, torch::optim::Optimizer& optimizer, int64_t& step) {
  return [&trainable, &optimizer, &step](torch::serialize::InputArchive& archive) {
    trainable.load(archive);
    torch::serialize::InputArchive optimizer_archive;
    archive.read(kOptimizerKey, optimizer_archive);
    try {
      optimizer.load(optimizer_archive);
    } catch (const c10::Error& e) {
      throw Error(fmt::format(
          "its optimizer state does not match this model's {} parameter groups (checkpoints written before "
          "the skinning network got its own learning rate have one group); it can still be evaluated, meshed "
          "and animated, but not resumed ({})",
          optimizer.param_groups().size(), e.what_without_backtrace()));
    }
    torch::Tensor t;
    archive.read("step", t);
    step = t.item<int64_t>();
  };
}

// Every parameter in exactly one optimiser group: a model that forgets one
// would silently not train it.
void check_groups(Trainable& trainable, const std::vector<OptimizerGroup>& groups) {
  size_t grouped = 0;
  for (const auto& group : groups) grouped += group.parameters.size();
  const size_t all = trainable.parameters().size();
  FSKIN_CHECK(grouped == all, "train: the model's parameter groups hold {} of its {} parameters", grouped, all);
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

struct BestScore {
  int64_t step = -1;
  double score = 0;
  nlohmann::json scores;
};

std::optional<BestScore> read_best(const RunDirectory& run, const std::string& score_key) {
  const auto path = run.best_scores_file();
  if (!fs::exists(path) || !fs::exists(run.best_checkpoint_file())) return std::nullopt;
  try {
    auto j = nlohmann::json::parse(read_file(path));
    return BestScore{j.at("step").get<int64_t>(), j.at(score_key).get<double>(), j};
  } catch (const nlohmann::json::exception& e) {
    fail("{}: malformed ({})", path, e.what());
  }
}

// The means of the values of the steps since the last log line ("step",
// "threads" and "lr" are the last step's).
class LogAccumulator {
 public:
  void add(const nlohmann::json& values) {
    for (auto it = values.begin(); it != values.end(); ++it) sums_[it.key()] += it.value().get<double>();
    last_ = values;
    ++count_;
  }
  nlohmann::json line() const {
    nlohmann::json out = last_;
    for (const auto& [key, sum] : sums_) {
      if (key != "step" && key != "threads" && key != "lr") out[key] = sum / static_cast<double>(count_);
    }
    return out;
  }
  void clear() {
    sums_.clear();
    count_ = 0;
  }

 private:
  std::map<std::string, double> sums_;
  nlohmann::json last_;
  int64_t count_ = 0;
};

// What the ranks agree on after a step's one all-reduce.
struct StepAgreement {
  bool has_gradient = false;  // some rank had a gradient (e.g. no step before the bootstrap has none)
  bool stop = false;          // some rank was asked to stop
};

// One all-reduce for the step: every gradient (averaged; zeros where a rank
// has none, with a flag per parameter saying whether any rank had one), the
// logged values (averaged in place), and the ranks' stop requests.
StepAgreement exchange_step(DataParallel& parallel, const std::vector<torch::Tensor>& parameters, bool has_gradient,
                            torch::Tensor& logged_values, bool stop_requested) {
  std::vector<torch::Tensor> exchanged;
  auto flags = torch::zeros({static_cast<int64_t>(parameters.size()) + 2}, torch::kFloat64);
  auto* flag = flags.data_ptr<double>();
  for (size_t p = 0; p < parameters.size(); ++p) {
    auto& grad = parameters[p].mutable_grad();
    flag[p] = grad.defined() ? 1 : 0;
    if (!grad.defined()) grad = torch::zeros_like(parameters[p]);
    exchanged.push_back(grad);
  }
  flag[parameters.size()] = has_gradient ? 1 : 0;
  flag[parameters.size() + 1] = stop_requested ? 1 : 0;
  exchanged.push_back(flags);
  exchanged.push_back(logged_values);
  parallel.average(exchanged);
  for (size_t p = 0; p < parameters.size(); ++p) {
    if (flag[p] == 0) parameters[p].mutable_grad() = torch::Tensor();
  }
  return {flag[parameters.size()] > 0, flag[parameters.size() + 1] > 0};
}

}  // namespace

Trainer::Trainer(RunDirectory run, TrainerSettings settings) : run_(std::move(run)), settings_(std::move(settings)) {
  FSKIN_CHECK(settings_.steps >= 0, "train: steps must be >= 0, got {}", settings_.steps);
  FSKIN_CHECK(settings_.log_every >= 1 && settings_.checkpoint_every >= 1 && settings_.keep_checkpoints >= 1 &&
                  settings_.validate_every >= 0,
              "train: log and checkpoint intervals and kept checkpoints must be >= 1, the validation interval >= 0");
}

TrainerSummary Trainer::run(Trainable& trainable) const {
  const auto& s = settings_;
  const std::string& run_path = run_.path();
  DataParallel* const parallel = s.parallel;
  const bool writer = parallel == nullptr || parallel->rank() == 0;  // rank 0 alone writes the run
  const Shard shard{parallel ? parallel->rank() : 0, parallel ? parallel->world_size() : 1};
  std::vector<torch::optim::OptimizerParamGroup> groups;
  std::vector<double> base_rates;  // per group, before the schedule
  const auto optimizer_groups = trainable.optimizer_groups();
  check_groups(trainable, optimizer_groups);
  for (const auto& group : optimizer_groups) {
    groups.emplace_back(group.parameters,
                        std::make_unique<torch::optim::AdamOptions>(
                            torch::optim::AdamOptions(group.learning_rate).eps(s.adam_eps)));
    base_rates.push_back(group.learning_rate);
  }
  torch::optim::Adam adam(std::move(groups), torch::optim::AdamOptions(s.learning_rate).eps(s.adam_eps));

  TrainerSummary summary;
  int64_t step = 0;
  // A run killed before its first checkpoint has nothing to resume: it starts
  // again from step 0, which is what an uninterrupted run would have done.
  // Checkpoints that exist but fail their CRC stay an error.
  summary.resumed = s.resume && !run_.checkpoints().empty();
  if (s.resume && !summary.resumed && writer)
    std::fprintf(stderr, "fskin: %s has no checkpoint yet: training from step 0\n", run_path.c_str());
  if (summary.resumed) {
    FSKIN_CHECK(load_latest_checkpoint(run_path, state_reader(trainable, adam, step)).has_value(),
                "train --resume: no intact checkpoint in {}", run_path);
  }
  trainable.to(s.device);
  move_optimizer_state(adam, s.device);
  trainable.on_start(summary.resumed);
  if (parallel) {
    // Every rank starts from rank 0's parameters and step.
    parallel->broadcast_from_rank0(trainable.parameters());
    const auto start_step = torch::tensor({static_cast<double>(step)}, torch::kFloat64);
    parallel->broadcast_from_rank0({start_step});
    FSKIN_CHECK(start_step.item<double>() == static_cast<double>(step),
                "rank {}: the run's checkpoint is at step {} here and at step {} on rank 0: the run directory must be "
                "the same for every rank",
                parallel->rank(), step, start_step.item<double>());
  }

  if (writer) run_.start_logs(summary.resumed, step);
  const std::string score_key = trainable.validation_score();
  std::optional<BestScore> best = summary.resumed && writer ? read_best(run_, score_key) : std::nullopt;
  const std::string log_file = run_.log_file();
  std::ofstream log;
  if (writer) {
    log.open(log_file, std::ios::app);
    FSKIN_CHECK(log.good(), "train: cannot append to {}", log_file);
  }

  summary.first_step = step;
  const auto start = std::chrono::steady_clock::now();
  ProgressBar bar(s.progress_label, std::max<int64_t>(s.steps - step, 0), s.progress && writer);
  int64_t saved_step = summary.resumed ? step : -1;
  LogAccumulator accumulated;
  const auto save = [&] {
    if (writer) save_checkpoint(run_path, step, state_writer(trainable, adam, step), s.keep_checkpoints);
    saved_step = step;
  };
  const auto parameters = trainable.parameters();
  while (step < s.steps) {
    // One process stops before the step; ranks agree after it (below), so
    // that none waits for a step the others will not take.
    if (!parallel && s.stop && s.stop->requested()) {
      summary.stopped = true;
      break;
    }
    follow_free_cores();
    const auto step_start = std::chrono::steady_clock::now();
    const uint64_t seed = step_seed(s.seed, step);
    // Models may draw from the default generator during a step (the PINs'
    // bone dropout, the avatar's rays); seeding it per step keeps --resume
    // bit-for-bit.
    torch::manual_seed(seed ^ 0x2545f491u);
    StepLosses losses = trainable.step_losses(step, seed, shard);
    adam.zero_grad();
    bool has_gradient = losses.total.requires_grad();
    if (has_gradient) losses.total.backward();

    // The logged values, as one float64 vector: terms, then metrics.
    std::vector<torch::Tensor> logged;
    for (const auto& term : losses.terms) logged.push_back(term.second.detach().to(torch::kFloat64).reshape({1}));
    for (const auto& metric : losses.metrics) logged.push_back(metric.second.detach().to(torch::kFloat64).reshape({1}));
    torch::Tensor logged_values = logged.empty() ? torch::zeros({0}, torch::kFloat64) : torch::cat(logged);
    if (parallel) {
      try {
        const auto agreed = exchange_step(*parallel, parameters, has_gradient, logged_values,
                                          s.stop && s.stop->requested());
        has_gradient = agreed.has_gradient;
        summary.stopped = summary.stopped || agreed.stop;
      } catch (const Error& e) {
        fail("{}: step {}: {}; the last checkpoint{} is kept: start every rank again with --resume", run_path,
             step + 1, e.what(),
             saved_step >= 0 ? fmt::format(" (step {})", saved_step) : std::string(" (none yet)"));
      }
    }
    const double rate_scale = s.schedule.scale(step, s.steps);
    // The gradients' global norm (before clipping) goes to the log: spikes
    // there show a learning rate or a batch too large for the model.
    double grad_norm = std::numeric_limits<double>::quiet_NaN();
    torch::Tensor grad_norm_tensor;
    if (has_gradient) {
      if (s.grad_clip > 0) {
        grad_norm = torch::nn::utils::clip_grad_norm_(parameters, s.grad_clip);
      } else {
        std::vector<torch::Tensor> norms;
        for (const auto& p : parameters)
          if (p.grad().defined()) norms.push_back(p.grad().detach().norm().to(torch::kFloat64).reshape({1}));
        if (!norms.empty()) grad_norm_tensor = torch::cat(norms).norm().reshape({1});
      }
      for (size_t g = 0; g < adam.param_groups().size(); ++g) {
        static_cast<torch::optim::AdamOptions&>(adam.param_groups()[g].options()).lr(base_rates[g] * rate_scale);
      }
      adam.step();
      trainable.after_step(step, adam);
    }
    ++step;

    // One host read per step for everything the log shows.
    const auto host = (grad_norm_tensor.defined() ? torch::cat({logged_values, grad_norm_tensor.to(logged_values.device())})
                                                  : logged_values)
                          .cpu();
    const double* values = host.data_ptr<double>();
    if (grad_norm_tensor.defined()) grad_norm = values[host.numel() - 1];
    nlohmann::json line = {{"step", step}};
    double loss = 0;
    size_t k = 0;
    for (const auto& term : losses.terms) {
      line[term.first] = values[k];
      loss += values[k++];
    }
    for (const auto& metric : losses.metrics) line[metric.first] = values[k++];
    FSKIN_CHECK(std::isfinite(loss),
                "{}: the loss became {} at step {} (learning rate {:g}); training stopped and the last checkpoint{} is "
                "kept: {} and resume",
                run_path, loss, step, s.learning_rate,
                saved_step >= 0 ? fmt::format(" (step {})", saved_step) : std::string(" (none yet)"),
                s.learning_rate_hint);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - step_start).count();
    line["loss"] = loss;
    line["lr"] = s.learning_rate * rate_scale;
    line["seconds"] = seconds;
    line["threads"] = at::get_num_threads();
    if (std::isfinite(grad_norm)) line["grad_norm"] = grad_norm;
    for (const auto& [name, value] : losses.host_metrics) line[name] = value;
    if (!losses.throughput.first.empty())
      line[losses.throughput.first] = losses.throughput.second * shard.count / seconds;
    if (parallel) line["ranks"] = parallel->world_size();
    if (step == summary.first_step + 1) summary.first_values = line;
    summary.last_values = line;
    accumulated.add(line);
    if (step % s.log_every == 0 || step == s.steps) {
      summary.last_logged = accumulated.line();
      if (writer) log << summary.last_logged.dump() << "\n" << std::flush;
      accumulated.clear();
    }
    bar.advance(1, fmt::format("{} {:.2f} it/s", trainable.progress_text(line), 1.0 / seconds));
    if (step % s.checkpoint_every == 0) save();
    if (writer && s.validate_every > 0 && step % s.validate_every == 0) {
      const auto validation = trainable.validate();
      FSKIN_CHECK(validation.has_value(), "train: validation every {} steps, but this model has no validation data",
                  s.validate_every);
      nlohmann::json row = validation->scores;
      row["step"] = step;
      std::ofstream(run_.validation_log_file(), std::ios::app) << row.dump() << "\n" << std::flush;
      const double score = validation->scores.at(score_key).get<double>();
      if (!best || score > best->score) {
        nlohmann::json best_json = row;
        best_json.update(validation->details);
        best = BestScore{step, score, best_json};
        // The checkpoint first, then best.json naming it: a kill in between
        // leaves an older best.json whose score the new file only beats.
        write_checkpoint_file(run_.best_checkpoint_file(), state_writer(trainable, adam, step));
        write_file_atomically(run_.best_scores_file(), best_json.dump(2) + "\n");
      }
    }
    if (summary.stopped) break;
  }
  bar.finish();
  if (saved_step != step) save();
  // No rank leaves (closing rank 0's store) before the last checkpoint is written.
  if (parallel) parallel->barrier();
  summary.last_step = step;
  if (best) {
    summary.best_step = best->step;
    summary.best_scores = best->scores;
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace fskin
