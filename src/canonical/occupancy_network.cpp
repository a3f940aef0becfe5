#include "fskin/canonical/occupancy_network.h"

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/networks/frequency_encoding.h"

namespace fskin {

OccupancyNetworkOptions OccupancyNetworkOptions::snarf(int64_t pose_dim) {
  OccupancyNetworkOptions o;
  o.pose_dim = pose_dim;
  return o;
}

OccupancyNetworkOptions OccupancyNetworkOptions::fast_snarf(int64_t pose_dim) {
  OccupancyNetworkOptions o = snarf(pose_dim);
  o.pose_layer = 6;
  return o;
}

OccupancyNetworkOptions OccupancyNetworkOptions::demo(int64_t pose_dim) {
  OccupancyNetworkOptions o;
  o.hidden_dim = 128;
  o.hidden_layers = 4;
  o.skip_layers = {2};
  o.pose_dim = pose_dim;
  o.pose_layer = 2;
  return o;
}

void OccupancyNetworkOptions::validate() const {
  FSKIN_CHECK(hidden_dim > 0 && hidden_layers > 0, "occupancy network: hidden size {} x {} must be positive",
              hidden_layers, hidden_dim);
  FSKIN_CHECK(pose_dim >= 0, "occupancy network: pose_dim {} must be >= 0", pose_dim);
  FSKIN_CHECK(pose_dim == 0 || (pose_embedding_dim > 0 && pose_layer >= 0 && pose_layer <= hidden_layers),
              "occupancy network: pose_layer {} must be in 0..{} and pose_embedding_dim {} positive", pose_layer,
              hidden_layers, pose_embedding_dim);
  FSKIN_CHECK(encoding_frequencies >= 0 && encoding_frequencies <= 16,
              "occupancy network: encoding_frequencies {} must be in 0..16", encoding_frequencies);
  FSKIN_CHECK(init_radius > 0, "occupancy network: init_radius {} must be positive", init_radius);
  FSKIN_CHECK(hash_levels >= 0 && hash_levels <= kMaxHashLevels, "occupancy network: hash_levels {} must be in 0..{}",
              hash_levels, kMaxHashLevels);
  if (hash_levels > 0) {
    HashEncodingOptions h = hash;
    h.levels = hash_levels;
    h.validate();
  }
}

OccupancyNetworkImpl::OccupancyNetworkImpl(const OccupancyNetworkOptions& options) : options_(options) {
  options.validate();
  MlpOptions mlp;
  mlp.input_dim = 3 + 6 * options.encoding_frequencies;
  if (options.hash_levels > 0) {
    options_.hash.levels = options.hash_levels;
    mlp.input_dim += options_.hash.output_dim();
    hash_table_ = register_parameter("hash_table", hash_encoding_table(options_.hash));
  }
  mlp.output_dim = 1;
  mlp.hidden_dim = options.hidden_dim;
  mlp.hidden_layers = options.hidden_layers;
  mlp.skip_layers = options.skip_layers;
  mlp.geometric_init = options.geometric_init;
  mlp.geometric_init_radius = options.init_radius;
  if (options.pose_dim > 0) {
    mlp.condition_dim = options.pose_embedding_dim;
    mlp.condition_layer = options.pose_layer;
    pose_embedding_ = register_module(
        "pose_embedding", torch::nn::Linear(options.pose_dim, options.pose_embedding_dim));
  }
  mlp_ = register_module("mlp", Mlp(mlp));
}

torch::Tensor OccupancyNetworkImpl::encode(const torch::Tensor& x) const {
  const auto u = options_.input.apply(x);
  const auto frequencies = positional_encoding(u, options_.encoding_frequencies, frequency_window_);
  if (options_.hash_levels == 0) return frequencies;
  // The normalised box [-1, 1] (longest side) onto the hash grid's unit cube.
  const auto unit = ((u.reshape({-1, 3}) + 1) * 0.5).to(hash_table_.scalar_type());
  std::vector<int64_t> shape(x.sizes().begin(), x.sizes().end());
  shape.back() = options_.hash.output_dim();
  const auto features = hash_encoding(unit, hash_table_, options_.hash).to(frequencies.scalar_type()).view(shape);
  return torch::cat({frequencies, features}, -1);
}

torch::Tensor OccupancyNetworkImpl::forward(const torch::Tensor& x, const torch::Tensor& pose) {
  FSKIN_CHECK(x.dim() >= 2 && x.size(-1) == 3, "occupancy network: points must be [B, ..., 3], got {}",
              shape_string(x.sizes()));
  const auto encoded = encode(x);
  if (options_.pose_dim == 0) return mlp_->forward(encoded).squeeze(-1);
  FSKIN_CHECK(pose.defined() && pose.dim() == 2 && pose.size(0) == x.size(0) &&
                  pose.size(1) == options_.pose_dim,
              "occupancy network: pose must be [{}, {}], got {}", x.size(0), options_.pose_dim,
              pose.defined() ? shape_string(pose.sizes()) : std::string("none"));
  // One embedding per frame, broadcast to all of its points.
  std::vector<int64_t> view(x.dim(), 1), expanded(x.sizes().begin(), x.sizes().end());
  view.front() = x.size(0);
  view.back() = options_.pose_embedding_dim;
  expanded.back() = options_.pose_embedding_dim;
  const auto condition = pose_embedding_->forward(pose).view(view).expand(expanded);
  return mlp_->forward(encoded, condition).squeeze(-1);
}

}  // namespace fskin
