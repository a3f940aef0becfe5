#pragma once
// A tiny training setup on the synthetic limb, shared by the trainer and
// baseline tests: small networks, small batches, a few hundred steps at most.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "fskin/training/train_config.h"

namespace fskin::testing {

inline std::vector<double> training_angles() {
  std::vector<double> angles;
  for (int i = 0; i < 12; ++i) angles.push_back(-1.2 + 2.4 * i / 11.0);
  return angles;
}

inline TrainConfig tiny_config() {
  TrainConfig c;
  c.frames_per_batch = 2;
  c.surface_points = 200;
  c.uniform_points = 100;
  c.learning_rate = 3e-3;
  c.occupancy_hidden_dim = 32;
  c.occupancy_hidden_layers = 3;
  c.occupancy_skip_layers = {2};
  c.pose_conditioning = false;
  c.init_radius = 0.5;
  c.skinning_hidden_dim = 32;
  c.skinning_hidden_layers = 2;
  c.grid_resolution = 16;
  c.start_bones = "all";
  c.encoding_frequencies = 0;
  c.skinning_prior_steps = 0;
  c.decay_fraction = 0;
  c.warmup_steps = 0;
  c.skinning_learning_rate_factor = 1.0;
  c.canonical_sparsity_weight = 0;
  return c;
}

inline std::vector<double> log_column(const std::filesystem::path& run, const std::string& key) {
  std::ifstream in(run / "log.jsonl");
  std::vector<double> values;
  for (std::string line; std::getline(in, line);) values.push_back(nlohmann::json::parse(line).at(key).get<double>());
  return values;
}

inline double mean(const std::vector<double>& v, size_t begin, size_t end) {
  double s = 0;
  for (size_t i = begin; i < end; ++i) s += v[i];
  return s / static_cast<double>(end - begin);
}

}  // namespace fskin::testing
