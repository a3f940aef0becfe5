#include "fskin/training/config_schema.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>

#include "fskin/core/error.h"
#include "fskin/invertible/pose_encoding.h"
#include "fskin/models/model_registry.h"

namespace fskin {
namespace {

using nlohmann::json;

constexpr int64_t kNoMax = std::numeric_limits<int64_t>::max();

std::string integer_in(const json& v, int64_t lo, int64_t hi) {
  if (!v.is_number_integer()) return fmt::format("must be a whole number, got {}", v.dump());
  if (v.is_number_unsigned() && v.get<uint64_t>() > static_cast<uint64_t>(kNoMax))
    return fmt::format("must be at most {}, got {}", hi, v.dump());
  const auto x = v.get<int64_t>();
  if (x >= lo && x <= hi) return {};
  if (hi == kNoMax) return fmt::format("must be >= {}, got {}", lo, x);
  return fmt::format("must be from {} to {}, got {}", lo, hi, x);
}

// 0 (off) or lo..hi.
std::string zero_or_in(const json& v, int64_t lo, int64_t hi, const char* zero_means) {
  if (v.is_number_integer() && v.get<int64_t>() == 0) return {};
  if (integer_in(v, lo, hi).empty()) return {};
  return fmt::format("must be 0 ({}) or from {} to {}, got {}", zero_means, lo, hi, v.dump());
}

// A finite number in [lo, hi], or (lo, hi] / [lo, hi) where open.
std::string number_in(const json& v, double lo, double hi, bool lo_open = false, bool hi_open = false) {
  if (!v.is_number()) return fmt::format("must be a number, got {}", v.dump());
  const double x = v.get<double>();
  const bool ok = std::isfinite(x) && (lo_open ? x > lo : x >= lo) && (hi_open ? x < hi : x <= hi);
  if (ok) return {};
  if (std::isinf(hi)) return fmt::format("must be {} {}, got {}", lo_open ? ">" : ">=", lo, x);
  return fmt::format("must be in {}{}, {}{}, got {}", lo_open ? "(" : "[", lo, hi, hi_open ? ")" : "]", x);
}

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string one_of(const json& v, std::initializer_list<const char*> names) {
  std::string list;
  for (const auto* n : names) list += fmt::format("{}\"{}\"", list.empty() ? "" : ", ", n);
  if (!v.is_string()) return fmt::format("must be one of {}, got {}", list, v.dump());
  for (const auto* n : names)
    if (v.get<std::string>() == n) return {};
  return fmt::format("must be one of {}, got {}", list, v.dump());
}

// A check that runs a parser that throws fskin::Error naming the choices.
template <typename Parse>
std::string parsed_by(const json& v, Parse parse) {
  if (!v.is_string()) return fmt::format("must be a string, got {}", v.dump());
  try {
    parse(v.get<std::string>());
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

std::string integer_list(const json& v, size_t size, int64_t lo) {
  const bool ok = v.is_array() && (size == 0 || v.size() == size) &&
                  std::all_of(v.begin(), v.end(), [&](const json& x) { return integer_in(x, lo, kNoMax).empty(); });
  if (ok) return {};
  if (size == 0) return fmt::format("must be a list of whole numbers >= {}, got {}", lo, v.dump());
  return fmt::format("must be a list of {} whole numbers, each >= {}, got {}", size, lo, v.dump());
}

std::string boolean(const json& v) { return v.is_boolean() ? "" : fmt::format("must be true or false, got {}", v.dump()); }
std::string text(const json& v) { return v.is_string() ? "" : fmt::format("must be a string, got {}", v.dump()); }

std::string start_bones(const json& v) {
  if (!v.is_string()) return fmt::format("must be a string, got {}", v.dump());
  const auto s = v.get<std::string>();
  if (s == "default" || s == "smpl-training" || s == "all") return {};
  const std::string prefix = "automatic:";
  if (s.rfind(prefix, 0) != 0)
    return fmt::format("must be \"default\", \"smpl-training\", \"all\" or \"automatic:K\", got \"{}\"", s);
  const auto count = s.substr(prefix.size());
  const bool ok = !count.empty() && count.size() <= 4 && std::all_of(count.begin(), count.end(), ::isdigit) &&
                  std::stoll(count) >= 1;
  return ok ? "" : fmt::format("'{}': K in automatic:K must be a whole number from 1 to 9999", s);
}

// clang-format off
const std::vector<ConfigKey> kKeys = {
    {"model.type", "method", [](const json& v) { return parsed_by(v, parse_method); }},
    {"seed", "seed", [](const json& v) { return integer_in(v, 0, kNoMax); }},
    {"steps", "steps", [](const json& v) { return integer_in(v, 0, kNoMax); }},

    {"model.canonical.encoding.frequencies", "encoding_frequencies", [](const json& v) { return integer_in(v, 0, 16); }},
    {"model.canonical.encoding.coarse_to_fine.start", "encoding_window_start", [](const json& v) { return number_in(v, 0, 16); }},
    {"model.canonical.encoding.coarse_to_fine.fraction", "encoding_window_fraction", [](const json& v) { return number_in(v, 0, 1); }},
    {"model.canonical.encoding.hash.levels", "occupancy_hash_levels", [](const json& v) { return integer_in(v, 0, 32); }},
    {"model.canonical.encoding.hash.log2_table_size", "occupancy_hash_log2_table_size", [](const json& v) { return integer_in(v, 4, 24); }},
    {"model.canonical.encoding.hash.base_resolution", "occupancy_hash_base_resolution", [](const json& v) { return integer_in(v, 1, 1 << 20); }},
    {"model.canonical.encoding.hash.finest_resolution", "occupancy_hash_finest_resolution", [](const json& v) { return integer_in(v, 1, 1 << 20); }},
    {"model.canonical.network.hidden_dim", "occupancy_hidden_dim", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.canonical.network.hidden_layers", "occupancy_hidden_layers", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.canonical.network.skip_layers", "occupancy_skip_layers", [](const json& v) { return integer_list(v, 0, 0); }},
    {"model.canonical.network.init_radius", "init_radius", [](const json& v) { return number_in(v, 0, kInf, true); }},
    {"model.canonical.pose_conditioning.enabled", "pose_conditioning", boolean},
    {"model.canonical.pose_conditioning.embedding_dim", "pose_embedding_dim", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.canonical.pose_conditioning.layer", "pose_layer", [](const json& v) { return integer_in(v, 0, kNoMax); }},

    {"model.skinning.network.hidden_dim", "skinning_hidden_dim", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.skinning.network.hidden_layers", "skinning_hidden_layers", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.skinning.prior_steps", "skinning_prior_steps", [](const json& v) { return integer_in(v, 0, kNoMax); }},

    {"model.deformer.grid.resolution", "grid_resolution", [](const json& v) { return zero_or_in(v, 4, 1024, "use shape"); }},
    {"model.deformer.grid.thin_part_resolution", "thin_part_grid_resolution", [](const json& v) { return zero_or_in(v, 4, 1024, "off"); }},
    {"model.deformer.grid.thin_part_fraction", "thin_part_fraction", [](const json& v) { return number_in(v, 0, 1); }},
    {"model.deformer.grid.padding", "grid_padding", [](const json& v) { return number_in(v, 0, 1); }},
    {"model.deformer.grid.shape", "grid", [](const json& v) { return integer_list(v, 3, 2); }},
    {"model.deformer.start_bones", "start_bones", start_bones},
    {"model.deformer.max_iterations", "max_iterations", [](const json& v) { return integer_in(v, 0, kNoMax); }},
    {"model.deformer.snarf_roots", "snarf_roots", [](const json& v) { return one_of(v, {"converged", "in-box"}); }},
    {"model.deformer.implicit_gradient", "implicit_gradient", [](const json& v) { return one_of(v, {"default", "exact", "approximate"}); }},

    {"model.pin.layers", "pin_layers", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.pin.per_bone_dim", "pin_per_bone_dim", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.pin.pose_hidden_dim", "pin_pose_hidden_dim", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.pin.space_hidden_dim", "pin_space_hidden_dim", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.pin.space_output", "pin_space_output", [](const json& v) { return one_of(v, {"sine", "linear"}); }},
    {"model.pin.space_omega", "pin_space_omega", [](const json& v) { return number_in(v, 0, kInf, true); }},
    {"model.pin.map_hidden_dim", "pin_map_hidden_dim", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.pin.rotation", "pin_rotation", [](const json& v) { return parsed_by(v, parse_rotation_encoding); }},
    {"model.pin.pose_frame", "pin_pose_frame", [](const json& v) { return parsed_by(v, parse_pose_frame); }},
    {"model.pin.bone_dropout", "pin_bone_dropout", [](const json& v) { return number_in(v, 0, 1, false, true); }},
    {"model.parts.hidden_dim", "part_hidden_dim", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"model.parts.hidden_layers", "part_hidden_layers", [](const json& v) { return integer_in(v, 1, kNoMax); }},

    {"losses.bootstrap.epochs", "bootstrap_epochs", [](const json& v) { return number_in(v, 0, kInf); }},
    {"losses.bootstrap.points_per_bone", "bone_points_per_bone", [](const json& v) { return integer_in(v, 0, kNoMax); }},
    {"losses.bootstrap.joint_weight", "joint_weight_loss_weight", [](const json& v) { return number_in(v, 0, kInf); }},
    {"losses.bootstrap.bones", "bootstrap_bones", [](const json& v) { return one_of(v, {"all", "in-body"}); }},
    {"losses.canonical_sparsity.weight", "canonical_sparsity_weight", [](const json& v) { return number_in(v, 0, kInf); }},
    {"losses.canonical_sparsity.points", "canonical_sparsity_points", [](const json& v) { return integer_in(v, 1, kNoMax); }},

    {"optimizer.learning_rate", "learning_rate", [](const json& v) {
       const auto problem = number_in(v, 0, 1, true);
       return problem.empty() ? problem : problem + " (Adam's steps are about this size; the default is 3e-3)"; }},
    {"optimizer.grad_clip", "grad_clip", [](const json& v) { return number_in(v, 0, kInf); }},
    {"optimizer.learning_rate_factors.skinning", "skinning_learning_rate_factor", [](const json& v) { return number_in(v, 0, kInf, true); }},
    {"optimizer.learning_rate_factors.pin", "pin_learning_rate_factor", [](const json& v) { return number_in(v, 0, kInf, true); }},
    {"schedule.warmup.steps", "warmup_steps", [](const json& v) { return integer_in(v, 0, kNoMax); }},
    {"schedule.warmup.factor", "warmup_factor", [](const json& v) { return number_in(v, 0, 1, true); }},
    {"schedule.decay.fraction", "decay_fraction", [](const json& v) { return number_in(v, 0, 1); }},
    {"schedule.decay.thin_part_fraction", "thin_part_decay_fraction",
     [](const json& v) {
       if (v.is_number() && v.get<double>() == -1) return std::string();
       const auto problem = number_in(v, 0, 1);
       return problem.empty() ? problem : "must be -1 (keep schedule.decay.fraction) or " + problem;
     }},
    {"schedule.decay.factor", "decay_factor", [](const json& v) { return number_in(v, 0, 1, true); }},

    {"data.path", "data", text},
    {"data.frames_per_batch", "frames_per_batch", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"data.surface_points", "surface_points", [](const json& v) { return integer_in(v, 0, kNoMax); }},
    {"data.uniform_points", "uniform_points", [](const json& v) { return integer_in(v, 0, kNoMax); }},
    {"data.validation_frames", "validation_frames", [](const json& v) { return integer_in(v, 1, kNoMax); }},

    {"run.checkpoint_every", "checkpoint_every", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"run.keep_checkpoints", "keep_checkpoints", [](const json& v) { return integer_in(v, 1, kNoMax); }},
    {"run.validate_every", "validate_every", [](const json& v) { return integer_in(v, 0, kNoMax); }},
    {"run.eval_chunk_points", "eval_chunk_points", [](const json& v) { return integer_in(v, 1, kNoMax); }},
};
// clang-format on

// Components that come in kinds, and the kinds fskin has. model.type is a
// key of its own (the method); the encoding's type follows its hash levels.
constexpr const char* kEncodingType = "model.canonical.encoding.type";
struct FixedType {
  const char* path;
  const char* only;
};
constexpr FixedType kFixedTypes[] = {{"optimizer.type", "adam"}, {"schedule.type", "warmup-cosine"}};

json::json_pointer pointer(const std::string& path) {
  std::string p = "/" + path;
  std::replace(p.begin(), p.end(), '.', '/');
  try {
    return json::json_pointer(p);
  } catch (const json::exception&) {
    fail("config: '{}' is not a key path (names separated by dots)", path);
  }
}

bool is_section(const std::string& path) {
  if (path == kEncodingType) return false;
  for (const auto& key : kKeys)
    if (key.path.rfind(path + ".", 0) == 0) return true;
  return false;
}

class Flattener {
 public:
  explicit Flattener(std::string context) : context_(std::move(context)) {}

  void walk(const json& object, const std::string& prefix) {
    for (const auto& [name, value] : object.items()) {
      const std::string path = prefix.empty() ? name : prefix + "." + name;
      if (value.is_object() && is_section(path)) {
        walk(value, path);
      } else if (path == kEncodingType) {
        encoding_type_ = value;
      } else if (const auto* fixed = fixed_type(path)) {
        FSKIN_CHECK(value == fixed->only, "{}: {}: must be \"{}\" (the only kind fskin has), got {}", context_, path,
                    fixed->only, value.dump());
      } else {
        // The nested path, or a flat name at the top level (old run configs,
        // `--set grid_resolution=48`).
        const ConfigKey* key = find_config_key(path);
        FSKIN_CHECK(key != nullptr && (key->path == path || prefix.empty()), "{}: unknown config key '{}'", context_,
                    path);
        const auto problem = key->check(value);
        FSKIN_CHECK(problem.empty(), "{}: {}: {}", context_, key->path, problem);
        FSKIN_CHECK(!flat_.contains(key->flat), "{}: {} is given twice (as '{}' and by its other name)", context_,
                    key->path, path);
        flat_[key->flat] = value;
      }
    }
  }

  json finish() {
    if (encoding_type_.is_null()) return flat_;
    const auto problem = one_of(encoding_type_, {"frequency", "frequency+hash"});
    FSKIN_CHECK(problem.empty(), "{}: {}: {}", context_, kEncodingType, problem);
    const auto levels = flat_.value("occupancy_hash_levels", json());
    if (encoding_type_ == "frequency") {
      FSKIN_CHECK(levels.is_null() || levels == 0,
                  "{}: model.canonical.encoding.hash.levels: must be 0 with {} \"frequency\" (use \"frequency+hash\"), "
                  "got {}",
                  context_, kEncodingType, levels.dump());
      flat_["occupancy_hash_levels"] = 0;
    } else {
      FSKIN_CHECK(!levels.is_null() && levels.get<int64_t>() >= 1,
                  "{}: {} \"frequency+hash\" needs model.canonical.encoding.hash.levels >= 1 in the same document "
                  "(setting the levels alone selects it)",
                  context_, kEncodingType);
    }
    return flat_;
  }

 private:
  static const FixedType* fixed_type(const std::string& path) {
    for (const auto& fixed : kFixedTypes)
      if (path == fixed.path) return &fixed;
    return nullptr;
  }

  std::string context_;
  json flat_ = json::object();
  json encoding_type_;
};

}  // namespace

const std::vector<ConfigKey>& config_keys() { return kKeys; }

const ConfigKey* find_config_key(const std::string& path_or_flat) {
  for (const auto& key : kKeys)
    if (key.path == path_or_flat || key.flat == path_or_flat) return &key;
  return nullptr;
}

json nest_config(const json& flat) {
  json nested = json::object();
  for (const auto& key : kKeys)
    if (flat.contains(key.flat)) nested[pointer(key.path)] = flat.at(key.flat);
  if (flat.contains("occupancy_hash_levels"))
    nested[pointer(kEncodingType)] = flat.at("occupancy_hash_levels") == 0 ? "frequency" : "frequency+hash";
  for (const auto& fixed : kFixedTypes) nested[pointer(fixed.path)] = fixed.only;
  return nested;
}

json flatten_config(const json& document, const std::string& context) {
  FSKIN_CHECK(document.is_object(), "{}: the config must be a JSON object", context);
  Flattener flattener(context);
  flattener.walk(document, "");
  return flattener.finish();
}

void check_config_values(const json& flat, const std::string& context) {
  for (const auto& key : kKeys) {
    if (!flat.contains(key.flat)) continue;
    const auto problem = key.check(flat.at(key.flat));
    FSKIN_CHECK(problem.empty(), "{}: {}: {}", context, key.path, problem);
  }
}

}  // namespace fskin
