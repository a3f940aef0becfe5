#include "fskin/models/occupancy_model.h"

#include "fskin/core/error.h"

namespace fskin {

torch::Tensor OccupancyModel::canonical_logits(const torch::Tensor&, const torch::Tensor&) {
  fail("this method has no canonical shape (it predicts occupancy in posed space only)");
}

torch::Tensor OccupancyModel::repose(const torch::Tensor&, const torch::Tensor&) {
  fail("this method has no map from canonical to posed space (it cannot re-pose a canonical mesh)");
}

std::vector<OccupancyModel::ParameterGroup> OccupancyModel::parameter_groups(double learning_rate) {
  return {{parameters(), learning_rate}};
}

}  // namespace fskin
