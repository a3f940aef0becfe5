#include "fskin/models/method.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "fskin/core/error.h"

namespace fskin {

namespace {
const std::vector<std::pair<Method, std::string>>& table() {
  static const std::vector<std::pair<Method, std::string>> t = {
      {Method::FastSnarf, "fast-snarf"}, {Method::Snarf, "snarf"}, {Method::PoseOnet, "pose-onet"},
      {Method::BackLbs, "back-lbs"},     {Method::BackD, "back-d"}, {Method::Piecewise, "piecewise"}, {Method::Ins, "ins"},
  };
  return t;
}
}  // namespace

const std::vector<std::string>& method_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& [method, name] : table()) n.push_back(name);
    return n;
  }();
  return names;
}

Method parse_method(const std::string& name) {
  for (const auto& [method, n] : table())
    if (n == name) return method;
  fail("unknown method '{}' (expected one of {})", name, fmt::join(method_names(), ", "));
}

std::string method_name(Method method) {
  for (const auto& [m, name] : table())
    if (m == method) return name;
  fail("method_name: unknown method {}", static_cast<int>(method));
}

}  // namespace fskin
