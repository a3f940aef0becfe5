#pragma once
// Config documents as data, for components whose defaults are a complete
// nested JSON document (the avatars', radiance/avatar_config.h and
// gaussians/gaussian_config.h): `--set
// a.b.c=v` assignments and overlays checked against the defaults, with errors
// that name the key path. (The occupancy models' config has a per-key schema
// of its own on top of this: training/config_schema.h.)
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "fskin/core/error.h"

namespace fskin {

// "a.b.c=v" -> {"a": {"b": {"c": v}}}; v is read as JSON (48, 0.5, true,
// [1, 2]) and otherwise taken as a string (method=snarf). Throws fskin::Error
// naming `context` when there is no key or no '='.
nlohmann::json assignment_overlay(const std::string& assignment, const std::string& context);

// Writes every leaf of `overlay` into `base`. Each key path must exist in
// `base` ("context: model.field.foo: unknown key (known: ...)") and keep its
// kind: a whole number for a whole number, a number for a number, a string,
// true / false, a list, or an object ("context: steps: must be a whole
// number, got "many""). Values are not range-checked here; the component's
// validate() does that.
void overlay_document(nlohmann::json& base, const nlohmann::json& overlay, const std::string& context);

// Components that come in one kind so far: (JSON pointer, the one value),
// e.g. {"/model/type", "gaussian-avatar"}.
using FixedKinds = std::vector<std::pair<std::string, std::string>>;
// Checks that a whole document holds each fixed kind and a "seed" >= 0
// ("context: model.type: must be "x" (the only kind so far), got "y"").
void check_document_kinds(const nlohmann::json& document, const FixedKinds& fixed, const std::string& context);

// The JSON document in the file at `path`; errors name the file.
nlohmann::json read_json_document(const std::string& path);

// A component's options as a table of fields, each once: a JSON pointer
// `path` into the nested document, `read(options) -> json` and
// `write(options, json)` (the tables live in the components' config files).
// The document of `options`: the fixed kinds and every field.
template <typename Options, typename Fields>
nlohmann::json fields_document(const Options& options, const Fields& fields, const FixedKinds& fixed) {
  nlohmann::json d = nlohmann::json::object();
  for (const auto& [path, only] : fixed) d[nlohmann::json::json_pointer(path)] = only;
  for (const auto& field : fields) d[nlohmann::json::json_pointer(field.path)] = field.read(options);
  return d;
}

// `given` (a whole or partial document; "format" and "fskin_version" are
// ignored) over base's document: overlaid, the kinds checked, read back into
// the options and validated, every error prefixed with `context`.
template <typename Options, typename Fields>
Options options_from_fields(nlohmann::json given, const Options& base, const Fields& fields, const FixedKinds& fixed,
                            const std::string& context) {
  FSKIN_CHECK(given.is_object(), "{}: the config must be a JSON object, got {}", context, given.type_name());
  given.erase("format");
  given.erase("fskin_version");
  nlohmann::json d = fields_document(base, fields, fixed);
  overlay_document(d, given, context);
  check_document_kinds(d, fixed, context);
  Options o = base;
  for (const auto& field : fields) field.write(o, d.at(nlohmann::json::json_pointer(field.path)));
  try {
    o.validate();
  } catch (const Error& error) {
    fail("{}: {}", context, error.what());
  }
  return o;
}

}  // namespace fskin
