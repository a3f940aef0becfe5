#pragma once
// An occupancy model as the engine trains it (engine/trainable.h): BCE on
// posed occupancy with the soft-max aggregation (SNARF eq. 6-7), plus the
// bootstrap losses during the first epoch and the configured priors
// (losses/); the skinning prior fitted before the first step of a new run;
// the best checkpoint chosen by IoU_surf on validation frames.
#include <memory>
#include <vector>

#include "fskin/engine/trainable.h"
#include "fskin/evaluation/evaluation_frame.h"
#include "fskin/data/point_sampling.h"
#include "fskin/models/occupancy_model.h"
#include "fskin/training/batch_source.h"
#include "fskin/training/train_config.h"

namespace fskin {

class OccupancyTrainable : public Trainable {
 public:
  // `skeleton`: the bones the bootstrap losses and the skinning prior use.
  // `validation` may be null when config.validate_every == 0.
  OccupancyTrainable(std::shared_ptr<OccupancyModel> model, const TrainConfig& config, const BatchSource& source,
                     CanonicalSkeleton skeleton, const std::vector<OccupancyFrame>* validation);

  std::vector<OptimizerGroup> optimizer_groups() override;
  std::vector<torch::Tensor> parameters() override;
  void save(torch::serialize::OutputArchive& archive) override;
  void load(torch::serialize::InputArchive& archive) override;
  void to(const torch::Device& device) override;
  void on_start(bool resumed) override;
  StepLosses step_losses(int64_t step, uint64_t seed, const Shard& shard) override;
  std::string progress_text(const nlohmann::json& step_values) const override;
  std::optional<ValidationResult> validate() override;
  std::string validation_score() const override { return "iou_surf"; }

  // Cross-entropy of the skinning prior's warm start (0: none ran).
  double skinning_prior_loss() const { return skinning_prior_loss_; }
  // The archive key of the model in checkpoints.
  static constexpr const char* kArchiveKey = "model";

 private:
  std::shared_ptr<OccupancyModel> model_;
  const TrainConfig& config_;
  const BatchSource& source_;
  CanonicalSkeleton skeleton_;
  const std::vector<OccupancyFrame>* validation_;
  torch::Device device_ = torch::kCPU;
  int64_t bootstrap_steps_ = 0;
  bool use_sparsity_ = false;
  Box canonical_box_;
  double skinning_prior_loss_ = 0;
};

}  // namespace fskin
