#pragma once
// Builds the model a training config describes, for any method.
#include <memory>

#include "fskin/training/occupancy_model.h"
#include "fskin/training/train_config.h"

namespace fskin {

std::shared_ptr<OccupancyModel> make_model(const TrainConfig& config, const CanonicalSkeleton& skeleton);

}  // namespace fskin
