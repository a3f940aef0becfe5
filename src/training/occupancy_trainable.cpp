#include "fskin/training/occupancy_trainable.h"

#include <ATen/CPUGeneratorImpl.h>
#include <fmt/format.h>

#include "fskin/core/error.h"
#include "fskin/engine/trainer.h"
#include "fskin/evaluation/evaluation.h"
#include "fskin/losses/bootstrap_losses.h"
#include "fskin/losses/canonical_sparsity.h"
#include "fskin/losses/skinning_prior.h"

namespace fskin {

namespace {

OccupancyBatch to_device(OccupancyBatch batch, const torch::Device& device) {
  return {batch.points.to(device), batch.occupancy.to(device), batch.bone_transforms.to(device),
          batch.pose.to(device)};
}

}  // namespace

OccupancyTrainable::OccupancyTrainable(std::shared_ptr<OccupancyModel> model, const TrainConfig& config,
                                       const BatchSource& source, CanonicalSkeleton skeleton,
                                       const std::vector<OccupancyFrame>* validation)
    : model_(std::move(model)),
      config_(config),
      source_(source),
      skeleton_(std::move(skeleton)),
      validation_(validation),
      bootstrap_steps_(config.bootstrap_steps(source.num_frames())),
      use_sparsity_(config.canonical_sparsity_weight > 0 && model_->has_canonical_shape()),
      canonical_box_(use_sparsity_ ? canonical_bounds(skeleton_) : Box{}) {
  model_->train(true);
}

std::vector<OptimizerGroup> OccupancyTrainable::optimizer_groups() {
  std::vector<OptimizerGroup> groups;
  for (auto& group : model_->parameter_groups(config_.learning_rate))
    groups.push_back({group.parameters, group.learning_rate});
  return groups;
}

std::vector<torch::Tensor> OccupancyTrainable::parameters() { return model_->parameters(); }

void OccupancyTrainable::save(torch::serialize::OutputArchive& archive) {
  torch::serialize::OutputArchive model_archive;
  model_->save(model_archive);
  archive.write(kArchiveKey, model_archive);
}

void OccupancyTrainable::load(torch::serialize::InputArchive& archive) {
  torch::serialize::InputArchive model_archive;
  archive.read(kArchiveKey, model_archive);
  model_->load(model_archive);
}

void OccupancyTrainable::to(const torch::Device& device) {
  device_ = device;
  model_->to(device);
}

void OccupancyTrainable::on_start(bool resumed) {
  if (!resumed && config_.skinning_prior_steps > 0 && model_->canonical_skinning_field() != nullptr) {
    skinning_prior_loss_ = fit_skinning_prior(*model_->canonical_skinning_field(), skeleton_,
                                              config_.skinning_prior_steps, config_.learning_rate,
                                              step_seed(config_.seed, -1));
  }
}

StepLosses OccupancyTrainable::step_losses(int64_t step, uint64_t seed, const Shard& shard) {
  const int64_t frames = config_.frames_per_batch;
  FSKIN_CHECK(frames % shard.count == 0,
              "train: frames_per_batch = {} does not split into {} equal shares, one per rank; set it to a multiple "
              "of the number of ranks",
              frames, shard.count);
  // The whole batch is drawn on every rank; a rank's BCE covers its share of
  // the frames, the priors (which do not depend on the batch's points) the
  // whole batch, so the mean over the ranks is one process's loss.
  const auto whole =
      to_device(source_.batch(frames, config_.surface_points, config_.uniform_points, seed), device_);
  model_->set_frequency_window(frequency_window(config_, step));
  OccupancyBatch batch = whole;
  if (shard.count > 1) {
    const int64_t share = frames / shard.count, first = shard.index * share;
    batch = {whole.points.narrow(0, first, share), whole.occupancy.narrow(0, first, share),
             whole.bone_transforms.narrow(0, first, share), whole.pose.narrow(0, first, share)};
  }
  auto prediction = model_->predict(batch.points, batch.bone_transforms, batch.pose, Aggregation::Soft);
  const auto bce = torch::binary_cross_entropy_with_logits(prediction.logits, batch.occupancy);
  StepLosses out;
  out.total = bce;
  auto bootstrap = torch::zeros({}, bce.options());
  if (step < bootstrap_steps_) {
    auto generator = at::make_generator<at::CPUGeneratorImpl>(seed);
    const BootstrapInputs inputs{&skeleton_, sample_bone_points(skeleton_, config_.bone_points_per_bone, generator),
                                 whole.pose, config_.joint_weight_loss_weight};
    const auto extra = bootstrap_loss(*model_, inputs);
    if (extra.defined()) {
      bootstrap = extra.detach();
      out.total = out.total + extra;
    }
  }
  auto sparsity = torch::zeros({}, bce.options());
  if (use_sparsity_) {
    auto generator = at::make_generator<at::CPUGeneratorImpl>(seed ^ 0x5bd1e995u);  // not the bootstrap's stream
    const auto prior = config_.canonical_sparsity_weight *
                       canonical_sparsity_loss(*model_, canonical_box_, whole.pose, config_.canonical_sparsity_points,
                                               generator);
    sparsity = prior.detach();
    out.total = out.total + prior;
  }
  out.terms = {{"bce", bce.detach()}, {"bootstrap", bootstrap}, {"sparsity", sparsity}};
  // The batch's IoU (evaluation/iou.h's convention: an empty union is 1); with
  // several ranks, the log shows the mean of their shares' IoUs.
  const auto predicted = prediction.logits.detach() > 0, truth = batch.occupancy > 0.5;
  const auto intersection = (predicted & truth).sum().to(torch::kFloat64);
  const auto union_ = (predicted | truth).sum().to(torch::kFloat64);
  out.metrics = {{"batch_iou", torch::where(union_ == 0, torch::ones_like(union_), intersection / union_)}};
  out.throughput = {"points_per_s", static_cast<double>(batch.points.size(0) * batch.points.size(1))};
  out.host_metrics = {{"deformer_s", prediction.deformer_seconds},
                      {"valid_per_point", prediction.deformer.mean_valid}};
  return out;
}

std::string OccupancyTrainable::progress_text(const nlohmann::json& values) const {
  return fmt::format("loss {:.4f} iou {:.3f}", values.at("bce").get<double>(), values.at("batch_iou").get<double>());
}

std::optional<ValidationResult> OccupancyTrainable::validate() {
  if (validation_ == nullptr || validation_->empty()) return std::nullopt;
  const auto scores = evaluate(*model_, *validation_, "val", config_.eval_chunk_points);
  model_->train(true);
  return ValidationResult{{{"iou_bbox", scores.mean_iou_bbox}, {"iou_surf", scores.mean_iou_surf}},
                          {{"frames", validation_->size()}}};
}

}  // namespace fskin
