#pragma once
// The layout of a training config as data: one nested JSON object per
// component (model -> canonical field (encoding + network) / skinning field /
// deformer / PINs / parts, losses, optimizer, schedule, data, run), each with
// its defaults (TrainConfig) and per-key validation whose messages name the
// key path ("model.deformer.grid.resolution: must be 0 or from 4 to 1024,
// got 2"). Components that come in kinds carry a `type` (tiny-cuda-nn's
// `otype`): model.type is the method, model.canonical.encoding.type
// "frequency" or "frequency+hash", optimizer.type "adam", schedule.type
// "warmup-cosine".
//
// TrainConfig stays the flat struct the C++ code reads; this file maps it to
// and from the nested documents that config files, `--set a.b.c=v`, run
// directories and `fskin config show` use. Flat documents (run directories
// written before the nested layout, and flat key names in --set) are
// converted on load.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace fskin {

struct ConfigKey {
  std::string path;  // nested key path, e.g. "model.deformer.grid.resolution"
  std::string flat;  // TrainConfig's field, e.g. "grid_resolution"
  // An empty string when `value` is allowed here, else what is wrong
  // ("must be >= 1, got 0"); checks the JSON type too.
  std::string (*check)(const nlohmann::json& value);
};

// Every key of a TrainConfig.
const std::vector<ConfigKey>& config_keys();

// The key with this nested path or flat name; nullptr if none.
const ConfigKey* find_config_key(const std::string& path_or_flat);

// A flat TrainConfig document -> the nested layout (adds the `type` keys).
nlohmann::json nest_config(const nlohmann::json& flat);

// A config document, nested or flat (or a mix: flat names at the top level
// are accepted as aliases of their paths), -> flat TrainConfig keys. Unknown
// keys, wrong `type`s and values that fail their key's check are errors
// naming `context` and the key path.
nlohmann::json flatten_config(const nlohmann::json& document, const std::string& context);

// The key-path check of every key of a flat document (as TrainConfig::validate
// runs it); throws fskin::Error "context: path: problem" on the first failure.
void check_config_values(const nlohmann::json& flat, const std::string& context);

}  // namespace fskin
