#include "fskin/engine/config_document.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

using json = nlohmann::json;

json assignment_overlay(const std::string& assignment, const std::string& context) {
  const auto eq = assignment.find('=');
  FSKIN_CHECK(eq != std::string::npos && eq > 0, "{} '{}': expected key=value", context, assignment);
  const std::string key = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  FSKIN_CHECK(key.find('/') == std::string::npos && key.find('~') == std::string::npos && key.back() != '.' &&
                  key.front() != '.' && key.find("..") == std::string::npos,
              "{} '{}': '{}' is not a key path", context, assignment, key);
  json value;
  try {
    value = json::parse(text);
  } catch (const json::exception&) {
    value = text;  // a bare string
  }
  std::string pointer = "/" + key;
  for (auto& c : pointer)
    if (c == '.') c = '/';
  json overlay = json::object();
  overlay[json::json_pointer(pointer)] = value;
  return overlay;
}

namespace {

std::string kind_problem(const json& expected, const json& value) {
  if (expected.is_number_integer() || expected.is_number_unsigned()) {
    return value.is_number_integer() || value.is_number_unsigned() ? ""
                                                                   : fmt::format("must be a whole number, got {}", value.dump());
  }
  if (expected.is_number()) return value.is_number() ? "" : fmt::format("must be a number, got {}", value.dump());
  if (expected.is_string()) return value.is_string() ? "" : fmt::format("must be a string, got {}", value.dump());
  if (expected.is_boolean()) return value.is_boolean() ? "" : fmt::format("must be true or false, got {}", value.dump());
  if (expected.is_array()) return value.is_array() ? "" : fmt::format("must be a list, got {}", value.dump());
  return "";
}

void overlay_at(json& base, const json& overlay, const std::string& path, const std::string& context) {
  for (const auto& [key, value] : overlay.items()) {
    const std::string here = path.empty() ? key : path + "." + key;
    if (!base.contains(key)) {
      std::vector<std::string> known;
      for (const auto& [name, unused] : base.items()) known.push_back(name);
      fail("{}: {}: unknown key (known{}: {})", context, here, path.empty() ? "" : " in " + path,
           fmt::join(known, ", "));
    }
    auto& target = base[key];
    if (target.is_object()) {
      FSKIN_CHECK(value.is_object(), "{}: {}: must be an object of keys, got {}", context, here, value.dump());
      overlay_at(target, value, here, context);
      continue;
    }
    const auto problem = kind_problem(target, value);
    FSKIN_CHECK(problem.empty(), "{}: {}: {}", context, here, problem);
    target = value;
  }
}

}  // namespace

void overlay_document(json& base, const json& overlay, const std::string& context) {
  FSKIN_CHECK(overlay.is_object(), "{}: the config must be a JSON object, got {}", context, overlay.type_name());
  overlay_at(base, overlay, "", context);
}

void check_document_kinds(const json& document, const FixedKinds& fixed, const std::string& context) {
  for (const auto& [path, only] : fixed) {
    std::string dotted = path.substr(1);
    std::replace(dotted.begin(), dotted.end(), '/', '.');
    FSKIN_CHECK(document.at(json::json_pointer(path)) == only, "{}: {}: must be \"{}\" (the only kind so far), got {}",
                context, dotted, only, document.at(json::json_pointer(path)).dump());
  }
  const auto& seed = document.at("seed");
  FSKIN_CHECK(seed.is_number_unsigned() || seed.get<int64_t>() >= 0, "{}: seed: must be >= 0, got {}", context,
              seed.dump());
}

json read_json_document(const std::string& path) {
  try {
    return json::parse(read_file(path));
  } catch (const json::exception& e) {
    fail("{}: {}", path, e.what());
  }
}

}  // namespace fskin
