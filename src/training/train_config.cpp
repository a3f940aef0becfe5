#include "fskin/training/train_config.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "fskin/core/error.h"
#include "fskin/engine/config_document.h"
#include "fskin/training/config_schema.h"
#include "fskin/deformers/start_bones.h"
#include "fskin/geometry/character_size.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

// Every field, in the flat document's order (nlohmann's own macro stops at 64 fields).
#define FSKIN_TRAIN_CONFIG_FIELDS(X) \
  X(data) X(method) X(seed) X(steps) X(frames_per_batch) X(surface_points) X(uniform_points) X(learning_rate) \
  X(grad_clip) X(warmup_steps) X(warmup_factor) X(decay_fraction) X(decay_factor) X(pin_layers) \
  X(pin_per_bone_dim) X(pin_pose_hidden_dim) X(pin_space_hidden_dim) X(pin_space_output) X(pin_space_omega) \
  X(pin_map_hidden_dim) X(pin_rotation) X(pin_pose_frame) X(pin_bone_dropout) X(pin_learning_rate_factor) \
  X(bootstrap_epochs) X(bone_points_per_bone) X(joint_weight_loss_weight) X(bootstrap_bones) \
  X(skinning_prior_steps) X(checkpoint_every) X(keep_checkpoints) X(validate_every) X(validation_frames) \
  X(occupancy_hidden_dim) X(occupancy_hidden_layers) X(occupancy_skip_layers) X(pose_conditioning) \
  X(pose_embedding_dim) X(pose_layer) X(encoding_frequencies) X(encoding_window_start) \
  X(encoding_window_fraction) X(occupancy_hash_levels) X(occupancy_hash_log2_table_size) \
  X(occupancy_hash_base_resolution) X(occupancy_hash_finest_resolution) X(init_radius) X(skinning_hidden_dim) \
  X(skinning_hidden_layers) X(skinning_learning_rate_factor) X(canonical_sparsity_weight) \
  X(canonical_sparsity_points) X(grid_resolution) X(thin_part_grid_resolution) X(thin_part_fraction) \
  X(thin_part_decay_fraction) \
  X(grid_padding) X(grid) X(part_hidden_dim) X(part_hidden_layers) X(start_bones) X(max_iterations) \
  X(snarf_roots) X(implicit_gradient) X(eval_chunk_points)

void to_json(nlohmann::json& j, const TrainConfig& c) {
#define FSKIN_FIELD_TO_JSON(field) j[#field] = c.field;
  FSKIN_TRAIN_CONFIG_FIELDS(FSKIN_FIELD_TO_JSON)
#undef FSKIN_FIELD_TO_JSON
}

// Missing keys keep their defaults (as NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT).
void from_json(const nlohmann::json& j, TrainConfig& c) {
  const TrainConfig defaults;
#define FSKIN_FIELD_FROM_JSON(field) c.field = j.value(#field, defaults.field);
  FSKIN_TRAIN_CONFIG_FIELDS(FSKIN_FIELD_FROM_JSON)
#undef FSKIN_FIELD_FROM_JSON
}

TrainConfig TrainConfig::full() {
  TrainConfig c;
  c.surface_points = 2000;
  c.uniform_points = 250;
  c.steps = 45000;
  c.checkpoint_every = 1000;
  c.occupancy_hidden_dim = 256;
  c.occupancy_hidden_layers = 8;
  c.occupancy_skip_layers = {4};
  c.pose_layer = 6;  // Fast-SNARF's choice; SNARF used 4
  c.learning_rate = 1e-3;
  c.decay_fraction = 0;
  c.warmup_steps = 0;
  c.skinning_learning_rate_factor = 1.0;
  c.canonical_sparsity_weight = 0;
  c.pose_conditioning = true;
  c.encoding_frequencies = 0;
  c.grid_resolution = 64;  // the papers' 64 along a person's longest side
  c.grid = {16, 64, 64};
  // INS: the paper's PINs (Table 4).
  c.pin_layers = 18;
  c.pin_pose_hidden_dim = 128;
  c.pin_space_hidden_dim = 64;
  c.pin_space_omega = 30;
  c.pin_map_hidden_dim = 32;
  c.pin_pose_frame = "global";
  c.pin_bone_dropout = 0;
  c.pin_learning_rate_factor = 0.1;
  return c;
}

void TrainConfig::use_method(const std::string& name) {
  method = name;
  if (name == "ins") {
    grad_clip = 4;
    canonical_sparsity_weight = 0;
  }
}

std::string TrainConfig::to_json() const { return nest_config(nlohmann::json(*this)).dump(2) + "\n"; }

std::string TrainConfig::to_flat_json() const { return nlohmann::json(*this).dump(2) + "\n"; }

namespace {

// K of "automatic:K" (throws fskin::Error naming the value unless 1 <= K <= 9999).
int64_t automatic_start_count(const std::string& spec) {
  const std::string count = spec.substr(std::string("automatic:").size());
  FSKIN_CHECK(!count.empty() && count.size() <= 4 && std::all_of(count.begin(), count.end(), ::isdigit) &&
                  std::stoll(count) >= 1,
              "config: start_bones '{}': K in automatic:K must be a whole number from 1 to 9999", spec);
  return std::stoll(count);
}

nlohmann::json parse_object(const std::string& text, const std::string& context) {
  nlohmann::json object;
  try {
    object = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail("{}: not valid JSON ({})", context, e.what());
  }
  FSKIN_CHECK(object.is_object(), "{}: the config must be a JSON object", context);
  return object;
}

}  // namespace

TrainConfig TrainConfig::from_json(const std::string& text, const std::string& context, const TrainConfig& base) {
  const nlohmann::json overlay = flatten_config(parse_object(text, context), context);
  nlohmann::json merged = base;
  for (const auto& [key, value] : overlay.items()) merged[key] = value;
  TrainConfig config;
  try {
    config = merged.get<TrainConfig>();
  } catch (const nlohmann::json::exception& e) {
    fail("{}: wrong value type ({})", context, e.what());
  }
  config.validate();
  return config;
}

TrainConfig TrainConfig::load(const std::string& path, const TrainConfig& base) {
  return from_json(read_file(path), path, base);
}

TrainConfig TrainConfig::load_run(const std::string& path) {
  // Keys added after run directories were first written, with the value a run
  // written without the key used.
  static const std::vector<std::pair<std::string, nlohmann::json>> kBeforeTheKeyExisted = {
      {"pin_space_output", "sine"}, {"pin_space_omega", 30.0}, {"pin_pose_frame", "global"}, {"pin_bone_dropout", 0.0},
      {"grid_resolution", 0}, {"thin_part_grid_resolution", 0}, {"thin_part_decay_fraction", -1.0},
      {"occupancy_hash_levels", 0}, {"bootstrap_bones", "all"}};
  nlohmann::json saved = parse_object(read_file(path), path);
  // Run directories written before the nested layout hold flat documents.
  const bool flat = !(saved.contains("model") && saved["model"].is_object());
  for (const auto& [key, value] : kBeforeTheKeyExisted) {
    if (flat && !saved.contains(key)) saved[key] = value;
  }
  return from_json(saved.dump(), path, TrainConfig{});
}

void TrainConfig::set(const std::string& assignment) {
  // A nested path (model.deformer.grid.resolution=48) or a flat name (grid_resolution=48).
  *this = from_json(assignment_overlay(assignment, "--set").dump(), "--set " + assignment, *this);
}

void TrainConfig::validate() const {
  // Each key on its own (config_schema.cpp), then what keys must satisfy together.
  check_config_values(nlohmann::json(*this), "config");
  FSKIN_CHECK(surface_points + uniform_points >= 1,
              "config: data.surface_points + data.uniform_points: a frame's batch of {} + {} points is empty",
              surface_points, uniform_points);
  FSKIN_CHECK(occupancy_hash_finest_resolution >= occupancy_hash_base_resolution,
              "config: model.canonical.encoding.hash.finest_resolution ({}) must be >= its base_resolution ({})",
              occupancy_hash_finest_resolution, occupancy_hash_base_resolution);
  FSKIN_CHECK(pose_layer <= occupancy_hidden_layers,
              "config: model.canonical.pose_conditioning.layer ({}) must be at most "
              "model.canonical.network.hidden_layers ({})",
              pose_layer, occupancy_hidden_layers);
}

int64_t TrainConfig::bootstrap_steps(int64_t frames) const {
  const double epoch = std::ceil(static_cast<double>(frames) / static_cast<double>(frames_per_batch));
  return static_cast<int64_t>(std::ceil(bootstrap_epochs * epoch));
}

namespace {
// Starts kept per point by "default" on skeletons without SMPL's names: as
// many as the papers' SMPL list has, so the search costs the same.
constexpr int64_t kDefaultAutomaticStarts = 9;

bool has_smpl_training_bones(const CanonicalSkeleton& skeleton) {
  for (const auto& name : StartBones::smpl_training_names())
    if (std::find(skeleton.joint_names.begin(), skeleton.joint_names.end(), name) == skeleton.joint_names.end())
      return false;
  return true;
}

StartBones resolve_start_bones(const std::string& spec, const CanonicalSkeleton& skeleton) {
  if (spec == "all") return StartBones::all();
  if (spec.rfind("automatic:", 0) == 0) return StartBones::automatic(automatic_start_count(spec));
  if (spec == "default" && !has_smpl_training_bones(skeleton))
    return StartBones::automatic(kDefaultAutomaticStarts);
  std::vector<int64_t> indices;
  for (const auto& name : StartBones::smpl_training_names()) {
    const auto it = std::find(skeleton.joint_names.begin(), skeleton.joint_names.end(), name);
    FSKIN_CHECK(it != skeleton.joint_names.end(),
                "start_bones smpl-training: the skeleton has no joint '{}' (use all or automatic:K)", name);
    indices.push_back(it - skeleton.joint_names.begin());
  }
  return StartBones::subset(indices);
}
}  // namespace

ModelOptions model_options(const TrainConfig& config, const CanonicalSkeleton& skeleton) {
  config.validate();
  const auto num_bones = static_cast<int64_t>(skeleton.parents.size());
  ModelOptions model;
  model.method = parse_method(config.method);
  auto& o = model.forward_skinning;
  o.method = model.method == Method::Snarf ? Method::Snarf : Method::FastSnarf;
  auto& occ = o.occupancy;
  occ.hidden_dim = config.occupancy_hidden_dim;
  occ.hidden_layers = config.occupancy_hidden_layers;
  occ.skip_layers = config.occupancy_skip_layers;
  // INS keeps the canonical shape pose-free: pose effects live in its PINs.
  occ.pose_dim = config.pose_conditioning && model.method != Method::Ins ? 3 * (num_bones - 1) : 0;
  occ.pose_embedding_dim = config.pose_embedding_dim;
  occ.pose_layer = config.pose_layer;
  occ.encoding_frequencies = config.encoding_frequencies;
  occ.hash_levels = config.occupancy_hash_levels;
  // Levels are at least 1 here so that the options validate; hash_levels 0 leaves the hash grid out.
  occ.hash = HashEncodingOptions::spanning(std::max<int64_t>(config.occupancy_hash_levels, 1),
                                           config.occupancy_hash_base_resolution,
                                           config.occupancy_hash_finest_resolution,
                                           config.occupancy_hash_log2_table_size);
  occ.init_radius = config.init_radius;
  occ.input = InputNormalization::around(skeleton.extent);
  o.skinning.num_bones = num_bones;
  o.skinning.hidden_dim = config.skinning_hidden_dim;
  o.skinning.hidden_layers = config.skinning_hidden_layers;
  o.skinning.input = occ.input;
  const auto extent = skeleton.extent.to(torch::kFloat64);
  o.box = config.grid_resolution > 0
              ? VoxelBox::fit(extent, config.grid_resolution, config.grid_padding)
              : VoxelBox::around(extent, GridShape{config.grid[0], config.grid[1], config.grid[2]});
  o.deformer = (model.method == Method::Snarf ? DeformerOptions::snarf() : DeformerOptions::fast_snarf())
                   .scaled(length_unit(extent, "training: the canonical body"));
  if (model.method == Method::Snarf && config.snarf_roots == "in-box") {
    o.deformer.root_box = o.box;
    o.deformer.remove_duplicates = true;
  }
  if (config.implicit_gradient != "default") {
    o.deformer.gradient = config.implicit_gradient == "exact" ? GradientMode::Exact : GradientMode::Approximate;
  }
  if (config.max_iterations > 0) o.deformer.max_iterations = static_cast<int>(config.max_iterations);
  o.deformer.start_bones = resolve_start_bones(config.start_bones, skeleton);
  model.pin.num_layers = config.pin_layers;
  model.pin.pose.num_bones = num_bones;
  model.pin.pose.per_bone_dim = config.pin_per_bone_dim;
  model.pin.pose.hidden_dim = config.pin_pose_hidden_dim;
  model.pin.pose.rotation = parse_rotation_encoding(config.pin_rotation);
  model.pin.pose.frame = parse_pose_frame(config.pin_pose_frame);
  model.pin.pose.parents = skeleton.parents;
  model.pin.pose.bone_dropout = config.pin_bone_dropout;
  model.pin.coupling.embedding_dim = model.pin.pose.embedding_dim();
  model.pin.coupling.space_hidden_dim = config.pin_space_hidden_dim;
  model.pin.coupling.space_linear_output = config.pin_space_output == "linear";
  model.pin.coupling.first_omega = config.pin_space_omega;
  model.pin.coupling.map_hidden_dim = config.pin_map_hidden_dim;
  model.pin_learning_rate_factor = config.pin_learning_rate_factor;
  model.part_hidden_dim = config.part_hidden_dim;
  model.part_hidden_layers = config.part_hidden_layers;
  o.skinning_learning_rate_factor = config.skinning_learning_rate_factor;
  return model;
}

double frequency_window(const TrainConfig& config, int64_t step) {
  const double opening_steps = config.encoding_window_fraction * static_cast<double>(config.steps);
  const double progress = opening_steps > 0 ? static_cast<double>(step + 1) / opening_steps : 1.0;
  if (progress >= 1.0) return std::numeric_limits<double>::infinity();
  const double frequencies = static_cast<double>(config.encoding_frequencies);
  const double start = std::min(config.encoding_window_start, frequencies);
  return start + (frequencies - start) * progress;
}

std::shared_ptr<OccupancyModel> make_model(const TrainConfig& config, const CanonicalSkeleton& skeleton) {
  return make_model(model_options(config, skeleton));
}

double fraction_outside_grid(const ModelOptions& options, const CanonicalSkeleton& skeleton) {
  if (options.method != Method::FastSnarf && options.method != Method::Ins) return 0.0;
  const auto inside = options.forward_skinning.box.contains(skeleton.extent.to(torch::kFloat32));
  return 1.0 - inside.to(torch::kFloat64).mean().item<double>();
}

}  // namespace fskin
