#pragma once
// The backward baselines of SNARF sec. 4.2: a network in *posed* space maps
// each posed point to one canonical point, where a canonical occupancy
// network (the same as SNARF's) is evaluated. Because the warp lives in posed
// space and is conditioned on the pose, it must learn every pose it meets, so
// it generalises poorly to unseen poses; SNARF's forward skinning does not.
// Subclasses define the warp (backward_lbs.h, backward_displacement.h).
#include "fskin/canonical/occupancy_network.h"
#include "fskin/networks/input_normalization.h"
#include "fskin/networks/mlp.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

// The posed-space network of a backward warp: root-frame posed points (and
// the pose condition, at the input) -> the warp's output.
struct BackwardWarpOptions {
  int64_t num_bones = 24;
  int64_t hidden_dim = 128;
  int64_t hidden_layers = 4;
  InputNormalization input;  // root-frame posed points -> network coordinates
};

class BackwardWarpModel : public OccupancyModel {
 public:
  OccupancyPrediction predict(const torch::Tensor& points, const torch::Tensor& bones, const torch::Tensor& pose,
                              Aggregation aggregation) override;
  bool has_canonical_shape() const override { return true; }
  torch::Tensor canonical_logits(const torch::Tensor& x_canonical, const torch::Tensor& pose) override;
  void set_frequency_window(double window) override { occupancy_->set_frequency_window(window); }

 protected:
  explicit BackwardWarpModel(const OccupancyNetworkOptions& occupancy);
  // The warp MLP's options: 3 inputs + the pose condition at layer 0, `output_dim` outputs.
  static MlpOptions warp_mlp_options(const BackwardWarpOptions& options, int64_t output_dim);
  // The pose condition [B, 3 (J - 1)] broadcast to every point of points [B, N, 3].
  static torch::Tensor pointwise_condition(const torch::Tensor& pose, const torch::Tensor& points);
  // Posed points [B, N, 3] -> one canonical point each [B, N, 3].
  virtual torch::Tensor to_canonical(const torch::Tensor& points, const torch::Tensor& bones,
                                     const torch::Tensor& pose) = 0;

 private:
  OccupancyNetworkOptions occupancy_options_;
  OccupancyNetwork occupancy_{nullptr};
};

}  // namespace fskin
