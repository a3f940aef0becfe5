#include "fskin/radiance/avatar_config.h"

#include <algorithm>
#include <filesystem>
#include <utility>

#include "fskin/core/error.h"
#include "fskin/engine/config_document.h"
#include "fskin/util/atomic_file.h"
#include "fskin/version.h"

namespace fskin {

using json = nlohmann::json;

namespace {

// The components that come in one kind so far; a document may name them.
constexpr std::pair<const char*, const char*> kFixedTypes[] = {{"/model/type", "fast-snarf-avatar"},
                                                              {"/model/field/encoding/type", "hash"},
                                                              {"/optimizer/type", "adam"},
                                                              {"/schedule/type", "cosine-decay"}};

// The flat avatar.json layout (runs written before the nested one): key -> path.
constexpr std::pair<const char*, const char*> kFlatKeys[] = {
    {"data_dir", "/data/path"},
    {"encoding", "/model/field/encoding"},
    {"hidden_dim", "/model/field/network/hidden_dim"},
    {"hidden_layers", "/model/field/network/hidden_layers"},
    {"skinning_grid_resolution", "/model/skinning/grid_resolution"},
    {"canonical_grid_resolution", "/model/occupancy_grid/canonical_resolution"},
    {"posed_grid_resolution", "/model/occupancy_grid/posed_resolution"},
    {"occupancy_opacity", "/model/occupancy_grid/opacity"},
    {"occupancy_every", "/model/occupancy_grid/every"},
    {"occupancy_warmup", "/model/occupancy_grid/warmup"},
    {"samples_per_diagonal", "/model/rendering/samples_per_diagonal"},
    {"start_bones", "/model/deformer/start_bones"},
    {"steps", "/steps"},
    {"seed", "/seed"},
    {"rays_per_step", "/data/rays_per_step"},
    {"images_per_step", "/data/images_per_step"},
    {"mask_box_fraction", "/data/mask_box_fraction"},
    {"background", "/data/background"},
    {"learning_rate", "/optimizer/learning_rate"},
    {"decay_fraction", "/schedule/decay_fraction"},
    {"decay_factor", "/schedule/decay_factor"},
    {"huber_delta", "/losses/colour/huber_delta"},
    {"opacity_weight", "/losses/opacity/weight"},
    {"checkpoint_every", "/run/checkpoint_every"},
    {"log_every", "/run/log_every"},
};

// A document of the flat layout holds a key only that layout has (seed and
// steps are in both).
bool is_flat(const json& document) {
  for (const auto& [key, value] : document.items()) {
    if (key == "seed" || key == "steps") continue;
    for (const auto& [flat_key, nested_path] : kFlatKeys)
      if (key == flat_key) return true;
  }
  return false;
}

json nested_from_flat(const json& flat, const std::string& context) {
  json nested = json::object();
  for (const auto& [key, value] : flat.items()) {
    const char* path = nullptr;
    for (const auto& [flat_key, nested_path] : kFlatKeys)
      if (key == flat_key) path = nested_path;
    FSKIN_CHECK(path != nullptr, "{}: {}: unknown key", context, key);
    nested[json::json_pointer(path)] = value;
  }
  return nested;
}

}  // namespace

json avatar_config_document(const AvatarTrainOptions& o) {
  const auto& a = o.avatar;
  const auto& e = a.field.encoding;
  json d = {
      {"model",
       {{"type", "fast-snarf-avatar"},
        {"field",
         {{"encoding",
           {{"type", "hash"},
            {"levels", e.levels},
            {"features_per_level", e.features_per_level},
            {"log2_table_size", e.log2_table_size},
            {"base_resolution", e.base_resolution},
            {"per_level_scale", e.per_level_scale}}},
          {"network", {{"hidden_dim", a.field.hidden_dim}, {"hidden_layers", a.field.hidden_layers}}}}},
        {"skinning", {{"grid_resolution", a.skinning_grid_resolution}}},
        {"deformer", {{"start_bones", a.start_bones}}},
        {"occupancy_grid",
         {{"canonical_resolution", a.canonical_grid_resolution},
          {"posed_resolution", a.posed_grid_resolution},
          {"opacity", a.occupancy_opacity},
          {"every", o.occupancy_every},
          {"warmup", o.occupancy_warmup}}},
        {"rendering", {{"samples_per_diagonal", a.samples_per_diagonal}}}}},
      {"losses", {{"colour", {{"huber_delta", o.huber_delta}}}, {"opacity", {{"weight", o.opacity_weight}}}}},
      {"optimizer", {{"type", "adam"}, {"learning_rate", o.learning_rate}}},
      {"schedule", {{"type", "cosine-decay"}, {"decay_fraction", o.decay_fraction}, {"decay_factor", o.decay_factor}}},
      {"data",
       {{"path", o.data_dir},
        {"rays_per_step", o.rays_per_step},
        {"images_per_step", o.images_per_step},
        {"mask_box_fraction", o.mask_box_fraction},
        {"background", o.background}}},
      {"run", {{"checkpoint_every", o.checkpoint_every}, {"log_every", o.log_every}}},
      {"seed", o.seed},
      {"steps", o.steps},
  };
  return d;
}

AvatarTrainOptions avatar_options_from_document(const json& document, const AvatarTrainOptions& base,
                                                const std::string& context) {
  FSKIN_CHECK(document.is_object(), "{}: the config must be a JSON object, got {}", context, document.type_name());
  json given = document;
  given.erase("format");
  given.erase("fskin_version");
  if (is_flat(given)) given = nested_from_flat(given, context);
  json d = avatar_config_document(base);
  overlay_document(d, given, context);
  for (const auto& [path, only] : kFixedTypes) {
    const auto pointer = json::json_pointer(path);
    std::string dotted = std::string(path).substr(1);
    std::replace(dotted.begin(), dotted.end(), '/', '.');
    FSKIN_CHECK(d.at(pointer) == only, "{}: {}: must be \"{}\" (the only kind so far), got {}", context, dotted, only,
                d.at(pointer).dump());
  }
  AvatarTrainOptions o = base;
  auto& a = o.avatar;
  auto& e = a.field.encoding;
  const auto& model = d.at("model");
  const auto& enc = model.at("field").at("encoding");
  e.levels = enc.at("levels");
  e.features_per_level = enc.at("features_per_level");
  e.log2_table_size = enc.at("log2_table_size");
  e.base_resolution = enc.at("base_resolution");
  e.per_level_scale = enc.at("per_level_scale");
  a.field.hidden_dim = model.at("field").at("network").at("hidden_dim");
  a.field.hidden_layers = model.at("field").at("network").at("hidden_layers");
  a.skinning_grid_resolution = model.at("skinning").at("grid_resolution");
  a.start_bones = model.at("deformer").at("start_bones");
  const auto& grid = model.at("occupancy_grid");
  a.canonical_grid_resolution = grid.at("canonical_resolution");
  a.posed_grid_resolution = grid.at("posed_resolution");
  a.occupancy_opacity = grid.at("opacity");
  o.occupancy_every = grid.at("every");
  o.occupancy_warmup = grid.at("warmup");
  a.samples_per_diagonal = model.at("rendering").at("samples_per_diagonal");
  o.huber_delta = d.at("losses").at("colour").at("huber_delta");
  o.opacity_weight = d.at("losses").at("opacity").at("weight");
  o.learning_rate = d.at("optimizer").at("learning_rate");
  o.decay_fraction = d.at("schedule").at("decay_fraction");
  o.decay_factor = d.at("schedule").at("decay_factor");
  const auto& data = d.at("data");
  o.data_dir = data.at("path");
  o.rays_per_step = data.at("rays_per_step");
  o.images_per_step = data.at("images_per_step");
  o.mask_box_fraction = data.at("mask_box_fraction");
  o.background = data.at("background");
  o.checkpoint_every = d.at("run").at("checkpoint_every");
  o.log_every = d.at("run").at("log_every");
  const bool negative_seed = !d.at("seed").is_number_unsigned() && d.at("seed").get<int64_t>() < 0;
  FSKIN_CHECK(!negative_seed, "{}: seed: must be >= 0, got {}", context, d.at("seed").dump());
  o.seed = d.at("seed");
  o.steps = d.at("steps");
  try {
    o.validate();
  } catch (const Error& error) {
    fail("{}: {}", context, error.what());
  }
  return o;
}

json avatar_run_document(const AvatarTrainOptions& o) {
  AvatarTrainOptions recorded = o;
  recorded.data_dir = std::filesystem::absolute(o.data_dir).string();
  auto document = avatar_config_document(recorded);
  document["format"] = "fskin-avatar-run";
  document["fskin_version"] = FSKIN_VERSION;
  return document;
}

AvatarTrainOptions read_avatar_run_config(const std::string& path, const std::string& run_dir) {
  json document;
  try {
    document = json::parse(read_file(path));
  } catch (const json::exception& e) {
    fail("{}: {}", path, e.what());
  }
  FSKIN_CHECK(document.is_object() && document.contains("format") && document.at("format") == "fskin-avatar-run", "{}: not an avatar run",
              path);
  AvatarTrainOptions base;
  base.out_dir = run_dir;
  base.data_dir = "(the run's dataset)";  // every run file names its own
  return avatar_options_from_document(document, base, path);
}

void set_avatar_option(AvatarTrainOptions& options, const std::string& assignment) {
  const std::string context = "--set " + assignment;
  // The data path may still be empty here (the CLI checks --data later); validate what --set can reach.
  options = avatar_options_from_document(assignment_overlay(assignment, "--set"), options, context);
}

}  // namespace fskin
