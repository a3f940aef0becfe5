#pragma once
// The avatar's training options as a config document, nested per component
// like the occupancy models' (training/config_schema.h):
//
//   model      type "fast-snarf-avatar"; field {encoding {type "hash", levels,
//              features_per_level, log2_table_size, base_resolution,
//              per_level_scale}, network {hidden_dim, hidden_layers}, shading};
//              skinning {grid_resolution}; deformer {start_bones};
//              occupancy_grid {canonical_resolution, posed_resolution,
//              opacity, every, warmup}; rendering {samples_per_diagonal}
//   losses     colour {huber_delta} (eq. 20), opacity {weight} (eq. 21)
//   optimizer  type "adam", learning_rate
//   schedule   type "cosine-decay", decay_fraction, decay_factor
//   data       path, rays_per_step, images_per_step, mask_box_fraction, background
//   pose_refinement  enabled, learning_rate, regularizer (pose_correction.h)
//   run        checkpoint_every, log_every
//   seed, steps
//
// A run directory's avatar.json is this document plus its format and the
// fskin version; runs written before the nested layout (flat keys) still load.
// `fskin avatar train --config FILE --set a.b.c=v` and `fskin config show RUN`
// use it.
#include <string>

#include <nlohmann/json.hpp>

#include "fskin/radiance/avatar_training.h"

namespace fskin {

nlohmann::json avatar_config_document(const AvatarTrainOptions& options);

// `document` (nested, or the flat layout of older avatar.json files) overlaid
// on `base`: unknown keys, wrong kinds and wrong `type`s are errors naming
// `context` and the key path; the result is validated. The format and
// fskin_version keys of a run file are accepted and ignored.
AvatarTrainOptions avatar_options_from_document(const nlohmann::json& document, const AvatarTrainOptions& base,
                                                const std::string& context);

// A run directory's avatar.json: the document with the data path made
// absolute, its format and the fskin version.
nlohmann::json avatar_run_document(const AvatarTrainOptions& options);
// The options a run recorded in `path` (its avatar.json, run directory
// `run_dir`), validated; every failure names the file.
AvatarTrainOptions read_avatar_run_config(const std::string& path, const std::string& run_dir);

// One `--set a.b.c=v` on `options`.
void set_avatar_option(AvatarTrainOptions& options, const std::string& assignment);

// What `fskin avatar train` (and Python's train_avatar) trains with: `base`
// (the command's arguments), then the JSON config file at `config_path`
// (none when empty), then each `a.b.c=v` setting, in that order.
AvatarTrainOptions configure_avatar_options(const AvatarTrainOptions& base, const std::string& config_path,
                                            const std::vector<std::string>& settings);

}  // namespace fskin
