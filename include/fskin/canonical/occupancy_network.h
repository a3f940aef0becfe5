#pragma once
// The canonical occupancy network f(x, p) of SNARF eq. 1: an IDR-style MLP
// (networks/mlp.h) from canonical points to occupancy logits. Optional pose
// conditioning: the pose vector is embedded by a Linear layer and
// concatenated at one hidden layer (SNARF: layer 4, Fast-SNARF: layer 6);
// without it the network is the pose-free "SNARF-NC" variant. Optional NeRF
// positional encoding of the input (the papers' clothed setup), and an
// optional hash-grid encoding.
#include <torch/torch.h>

#include <limits>
#include <vector>

#include "fskin/networks/input_normalization.h"
#include "fskin/networks/mlp.h"
#include "fskin/ops/hash_encoding.h"

namespace fskin {

struct OccupancyNetworkOptions {
  int64_t hidden_dim = 256;
  int64_t hidden_layers = 8;
  std::vector<int64_t> skip_layers{4};
  // Pose conditioning: width of the pose vector (0: pose-free), its embedding
  // width and the layer whose input gets the embedding.
  int64_t pose_dim = 0;
  int64_t pose_embedding_dim = 8;
  int64_t pose_layer = 4;
  // NeRF encoding frequencies (0: raw coordinates).
  int64_t encoding_frequencies = 0;
  // Multi-resolution hash encoding (ops/hash_encoding.h) of the point in the
  // normalised box, concatenated after the coordinates and their frequencies
  // (hash_levels 0: none). Its grids resolve parts much thinner than a few
  // hundred steps of an MLP on frequencies do.
  int64_t hash_levels = 0;
  HashEncodingOptions hash;  // levels is hash_levels
  // Canonical points -> network coordinates (applied before the encoding).
  InputNormalization input;
  // Geometric init: initially occupied inside a sphere of this radius (in
  // normalised coordinates) around `input.centre`.
  bool geometric_init = true;
  double init_radius = 1.0;

  // 8 x 256, skip at 4, pose embedded at layer 4 (SNARF) / 6 (Fast-SNARF).
  static OccupancyNetworkOptions snarf(int64_t pose_dim);
  static OccupancyNetworkOptions fast_snarf(int64_t pose_dim);
  // 4 x 128, skip and pose at layer 2: the CPU demo size.
  static OccupancyNetworkOptions demo(int64_t pose_dim);
  // Throws fskin::Error naming the bad field.
  void validate() const;
};

class OccupancyNetworkImpl : public torch::nn::Module {
 public:
  explicit OccupancyNetworkImpl(const OccupancyNetworkOptions& options);
  // Canonical points x [B, ..., 3] and pose [B, pose_dim] (required iff
  // pose_dim > 0) -> occupancy logits [B, ...].
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& pose = {});
  const OccupancyNetworkOptions& options() const { return options_; }
  // The frequency encoding's coarse-to-fine window (networks/frequency_encoding.h);
  // infinity, the default, opens every band. Not saved: a trainer sets it per step.
  void set_frequency_window(double window) { frequency_window_ = window; }
  double frequency_window() const { return frequency_window_; }

 private:
  torch::Tensor encode(const torch::Tensor& x) const;

  OccupancyNetworkOptions options_;
  double frequency_window_ = std::numeric_limits<double>::infinity();
  Mlp mlp_{nullptr};
  torch::Tensor hash_table_;  // [L, 2^T, F] when hash_levels > 0
  torch::nn::Linear pose_embedding_{nullptr};
};
TORCH_MODULE(OccupancyNetwork);

}  // namespace fskin
