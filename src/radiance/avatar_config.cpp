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
const FixedKinds kFixedKinds = {{"/model/type", "fast-snarf-avatar"},
                                {"/model/field/encoding/type", "hash"},
                                {"/optimizer/type", "adam"},
                                {"/schedule/type", "cosine-decay"}};

// Every option once: its path in the nested document, its key in the flat
// layout of runs written before it (the hash encoding was one flat object,
// "encoding"), and the member it reads and writes.
struct Field {
  const char* path;
  const char* flat;
  json (*read)(const AvatarTrainOptions&);
  void (*write)(AvatarTrainOptions&, const json&);
};

#define FSKIN_AVATAR_FIELD(path, flat, member)                                  \
  Field {                                                                       \
    path, flat, [](const AvatarTrainOptions& o) -> json { return o.member; },   \
        [](AvatarTrainOptions& o, const json& v) { v.get_to(o.member); }        \
  }

const Field kFields[] = {
    FSKIN_AVATAR_FIELD("/model/field/encoding/levels", "encoding/levels", avatar.field.encoding.levels),
    FSKIN_AVATAR_FIELD("/model/field/encoding/features_per_level", "encoding/features_per_level",
                       avatar.field.encoding.features_per_level),
    FSKIN_AVATAR_FIELD("/model/field/encoding/log2_table_size", "encoding/log2_table_size",
                       avatar.field.encoding.log2_table_size),
    FSKIN_AVATAR_FIELD("/model/field/encoding/base_resolution", "encoding/base_resolution",
                       avatar.field.encoding.base_resolution),
    FSKIN_AVATAR_FIELD("/model/field/encoding/per_level_scale", "encoding/per_level_scale",
                       avatar.field.encoding.per_level_scale),
    FSKIN_AVATAR_FIELD("/model/field/network/hidden_dim", "hidden_dim", avatar.field.hidden_dim),
    FSKIN_AVATAR_FIELD("/model/field/network/hidden_layers", "hidden_layers", avatar.field.hidden_layers),
    FSKIN_AVATAR_FIELD("/model/field/shading", "shading", avatar.field.shading),
    FSKIN_AVATAR_FIELD("/model/field/appearance/dim", "appearance_dim", avatar.field.appearance_dim),
    FSKIN_AVATAR_FIELD("/model/field/appearance/hidden_dim", "appearance_hidden_dim",
                       avatar.field.appearance_hidden_dim),
    FSKIN_AVATAR_FIELD("/model/skinning/grid_resolution", "skinning_grid_resolution", avatar.skinning_grid_resolution),
    FSKIN_AVATAR_FIELD("/model/skinning/type", "skinning", avatar.skinning),
    FSKIN_AVATAR_FIELD("/losses/skinning_prior/weight", "skinning_prior", skinning_prior),
    FSKIN_AVATAR_FIELD("/model/deformer/start_bones", "start_bones", avatar.start_bones),
    FSKIN_AVATAR_FIELD("/model/occupancy_grid/canonical_resolution", "canonical_grid_resolution",
                       avatar.canonical_grid_resolution),
    FSKIN_AVATAR_FIELD("/model/occupancy_grid/posed_resolution", "posed_grid_resolution", avatar.posed_grid_resolution),
    FSKIN_AVATAR_FIELD("/model/occupancy_grid/opacity", "occupancy_opacity", avatar.occupancy_opacity),
    FSKIN_AVATAR_FIELD("/model/occupancy_grid/every", "occupancy_every", occupancy_every),
    FSKIN_AVATAR_FIELD("/model/occupancy_grid/warmup", "occupancy_warmup", occupancy_warmup),
    FSKIN_AVATAR_FIELD("/model/rendering/samples_per_diagonal", "samples_per_diagonal", avatar.samples_per_diagonal),
    FSKIN_AVATAR_FIELD("/losses/colour/huber_delta", "huber_delta", huber_delta),
    FSKIN_AVATAR_FIELD("/losses/opacity/weight", "opacity_weight", opacity_weight),
    FSKIN_AVATAR_FIELD("/optimizer/learning_rate", "learning_rate", learning_rate),
    FSKIN_AVATAR_FIELD("/schedule/decay_fraction", "decay_fraction", decay_fraction),
    FSKIN_AVATAR_FIELD("/schedule/decay_factor", "decay_factor", decay_factor),
    FSKIN_AVATAR_FIELD("/data/path", "data_dir", data_dir),
    FSKIN_AVATAR_FIELD("/data/rays_per_step", "rays_per_step", rays_per_step),
    FSKIN_AVATAR_FIELD("/data/images_per_step", "images_per_step", images_per_step),
    FSKIN_AVATAR_FIELD("/data/mask_box_fraction", "mask_box_fraction", mask_box_fraction),
    FSKIN_AVATAR_FIELD("/data/background", "background", background),
    FSKIN_AVATAR_FIELD("/pose_refinement/enabled", "refine_poses", refine_poses),
    FSKIN_AVATAR_FIELD("/pose_refinement/learning_rate", "pose_learning_rate", pose_learning_rate),
    FSKIN_AVATAR_FIELD("/pose_refinement/regularizer", "pose_regularizer", pose_regularizer),
    FSKIN_AVATAR_FIELD("/run/checkpoint_every", "checkpoint_every", checkpoint_every),
    FSKIN_AVATAR_FIELD("/run/log_every", "log_every", log_every),
    FSKIN_AVATAR_FIELD("/seed", "seed", seed),
    FSKIN_AVATAR_FIELD("/steps", "steps", steps),
};
#undef FSKIN_AVATAR_FIELD

// A flat key's first name ("encoding" of "encoding/levels").
std::string flat_head(const char* flat) {
  const std::string key(flat);
  return key.substr(0, key.find('/'));
}

// A document of the flat layout holds a key only that layout has (seed and
// steps are in both).
bool is_flat(const json& document) {
  for (const auto& [key, value] : document.items()) {
    if (key == "seed" || key == "steps") continue;
    for (const auto& field : kFields)
      if (key == flat_head(field.flat)) return true;
  }
  return false;
}

json nested_from_flat(const json& flat, const std::string& context) {
  for (const auto& [key, value] : flat.items()) {
    const bool known = std::any_of(std::begin(kFields), std::end(kFields),
                                   [&key = key](const Field& field) { return key == flat_head(field.flat); });
    FSKIN_CHECK(known, "{}: {}: unknown key", context, key);
  }
  json nested = json::object();
  for (const auto& field : kFields) {
    const auto flat_pointer = json::json_pointer("/" + std::string(field.flat));
    if (flat.contains(flat_pointer)) nested[json::json_pointer(field.path)] = flat.at(flat_pointer);
  }
  return nested;
}

}  // namespace

json avatar_config_document(const AvatarTrainOptions& options) {
  return fields_document(options, kFields, kFixedKinds);
}

AvatarTrainOptions avatar_options_from_document(const json& document, const AvatarTrainOptions& base,
                                                const std::string& context) {
  FSKIN_CHECK(document.is_object(), "{}: the config must be a JSON object, got {}", context, document.type_name());
  json given = document;
  given.erase("format");
  given.erase("fskin_version");
  if (is_flat(given)) given = nested_from_flat(given, context);
  return options_from_fields(given, base, kFields, kFixedKinds, context);
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
  const json document = read_json_document(path);
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

AvatarTrainOptions configure_avatar_options(const AvatarTrainOptions& base, const std::string& config_path,
                                            const std::vector<std::string>& settings) {
  AvatarTrainOptions options = base;
  if (!config_path.empty()) {
    options = avatar_options_from_document(read_json_document(config_path), options, config_path);
  }
  for (const auto& setting : settings) set_avatar_option(options, setting);
  return options;
}

}  // namespace fskin
