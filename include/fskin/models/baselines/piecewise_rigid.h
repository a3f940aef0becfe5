#pragma once
// Piecewise rigid (SNARF sec. 4.2, the rigid variant of NASA): one small
// occupancy network per bone, each evaluated at the posed point carried back
// rigidly by that bone alone (x_j = B_j^-1 x'); the shape is the union of the
// parts, a max over bones (soft max in training). Rigid parts cannot bend
// smoothly at joints, which shows as cracks and bulges there.
#include <torch/torch.h>

#include "fskin/networks/input_normalization.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

struct PiecewiseRigidOptions {
  int64_t num_bones = 24;
  int64_t hidden_dim = 64;
  int64_t hidden_layers = 3;
  InputNormalization input;  // canonical points -> network coordinates
};

class PiecewiseRigidModel : public OccupancyModel {
 public:
  explicit PiecewiseRigidModel(const PiecewiseRigidOptions& options);
  OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones, const torch::Tensor& pose,
                              Aggregation aggregation) override;
  // Per-part logits of canonical points x [B, N, J, 3] (x[..., j, :] in part j's
  // rest frame) -> [B, N, J].
  torch::Tensor part_logits(const torch::Tensor& x);

 private:
  PiecewiseRigidOptions options_;
  // Layer l of all J part networks at once: weights [J, in, out], biases [J, out].
  std::vector<torch::Tensor> weights_, biases_;
};

}  // namespace fskin
