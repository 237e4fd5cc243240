#include "daemon/parallaxd/control_request.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <limits>

#include "common/input_error.h"

namespace parallax::daemon {
namespace {

[[noreturn]] void refuse(std::string_view key, const std::string& why) {
  throw InputError({"", std::string(key), 0}, why);
}

// JSON integers arrive as int64 or uint64; anything outside [lo, hi] is refused before it is
// narrowed, so no value wraps into range.
int64_t integerIn(const nlohmann::json& v, std::string_view key, int64_t lo, int64_t hi,
                  const std::string& what) {
  const std::string expected = fmt::format("must be {} from {} to {}", what, lo, hi);
  if (v.is_number_unsigned()) {
    const uint64_t u = v.get<uint64_t>();
    if (u > static_cast<uint64_t>(hi)) refuse(key, fmt::format("{}, got {}", expected, u));
    return static_cast<int64_t>(u);
  }
  if (!v.is_number_integer()) refuse(key, fmt::format("{}, got {}", expected, v.dump()));
  const int64_t i = v.get<int64_t>();
  if (i < lo || i > hi) refuse(key, fmt::format("{}, got {}", expected, i));
  return i;
}

double finiteIn(const nlohmann::json& v, std::string_view key, double lo, double hi) {
  if (!v.is_number()) refuse(key, fmt::format("must be a number, got {}", v.dump()));
  const double d = v.get<double>();
  if (!std::isfinite(d) || d < lo || d > hi)
    refuse(key, fmt::format("must be a number from {} to {}, got {}", lo, hi, v.dump()));
  return d;
}

std::string usageOf(const ArgSpec& a) {
  std::string range;
  switch (a.kind) {
    case ArgKind::kModule:
      range = "M";
      break;
    case ArgKind::kInteger:
      range = fmt::format("{}..{}", a.min, a.max);
      break;
    case ArgKind::kNumber:
      range = fmt::format("{}..{}", a.min, a.max);
      break;
    case ArgKind::kString:
      range = "TEXT";
      break;
    case ArgKind::kPath:
      range = "/ABSOLUTE/PATH";
      break;
    case ArgKind::kNumberMap:
      range = "{NAME: NUMBER}";
      break;
  }
  const std::string text = fmt::format("{}={}", a.name, range);
  return a.required ? text : "[" + text + "]";
}

}  // namespace

bool RequestArgs::has(std::string_view name) const { return values_.contains(name); }

std::optional<int> RequestArgs::module(std::string_view name) const {
  if (!has(name)) return std::nullopt;
  return values_.at(std::string(name)).get<int>();
}

int RequestArgs::integer(std::string_view name, int fallback) const {
  return has(name) ? values_.at(std::string(name)).get<int>() : fallback;
}

double RequestArgs::number(std::string_view name) const {
  return values_.at(std::string(name)).get<double>();
}

std::string RequestArgs::string(std::string_view name) const {
  return has(name) ? values_.at(std::string(name)).get<std::string>() : std::string();
}

std::map<std::string, double> RequestArgs::numberMap(std::string_view name) const {
  std::map<std::string, double> out;
  if (has(name)) {
    for (const auto& [k, v] : values_.at(std::string(name)).items()) out[k] = v.get<double>();
  }
  return out;
}

const RequestSpec* findControlRequest(std::string_view name) {
  for (const RequestSpec& spec : controlRequests()) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

std::string unknownRequestMessage(std::string_view name) {
  std::vector<std::string_view> names;
  for (const RequestSpec& spec : controlRequests()) names.push_back(spec.name);
  return fmt::format("unknown request \"{}\" ({})", name, fmt::join(names, ", "));
}

std::string controlRequestHelp() {
  std::vector<std::string> usages;
  size_t width = 0;
  for (const RequestSpec& spec : controlRequests()) {
    std::string usage(spec.name);
    for (const ArgSpec& a : spec.args) usage += " " + usageOf(a);
    width = std::max(width, usage.size());
    usages.push_back(std::move(usage));
  }
  std::string text;
  for (size_t i = 0; i < usages.size(); ++i)
    text += fmt::format("  {:<{}}  {}\n", usages[i], width, controlRequests()[i].help);
  return text;
}

RequestArgs parseRequestArgs(const RequestSpec& spec, const nlohmann::json& request, int modules) {
  for (const auto& [key, value] : request.items()) {
    if (key == "request") continue;
    bool known = false;
    for (const ArgSpec& a : spec.args) known = known || a.name == key;
    if (!known) {
      std::vector<std::string_view> names;
      for (const ArgSpec& a : spec.args) names.push_back(a.name);
      refuse(key, names.empty() ? fmt::format("unknown key: \"{}\" takes no arguments", spec.name)
                                : fmt::format("unknown key for \"{}\" (it takes {})", spec.name,
                                              fmt::join(names, ", ")));
    }
  }
  nlohmann::json checked = nlohmann::json::object();
  for (const ArgSpec& a : spec.args) {
    const std::string key(a.name);
    if (!request.contains(key)) {
      if (a.required) refuse(key, fmt::format("\"{}\" needs \"{}\"", spec.name, key));
      continue;
    }
    const nlohmann::json& v = request.at(key);
    switch (a.kind) {
      case ArgKind::kModule:
        if (modules < 1) refuse(key, "the display has no modules");
        checked[key] = integerIn(v, key, 0, modules - 1, "a module index");
        break;
      case ArgKind::kInteger:
        checked[key] = integerIn(v, key, static_cast<int64_t>(a.min), static_cast<int64_t>(a.max),
                                 "an integer");
        break;
      case ArgKind::kNumber:
        checked[key] = finiteIn(v, key, a.min, a.max);
        break;
      case ArgKind::kString:
      case ArgKind::kPath:
        if (!v.is_string() || v.get<std::string>().empty())
          refuse(key, fmt::format("must be a non-empty string, got {}", v.dump()));
        if (a.kind == ArgKind::kPath && v.get<std::string>().front() != '/') {
          refuse(key,
                 fmt::format("must be an absolute path (the daemon does not share your working "
                             "folder; `parallax ctl` makes relative paths absolute), got \"{}\"",
                             v.get<std::string>()));
        }
        checked[key] = v;
        break;
      case ArgKind::kNumberMap:
        if (!v.is_object()) refuse(key, "must be an object of numbers");
        for (const auto& [name, number] : v.items()) {
          finiteIn(number, key + "." + name, -std::numeric_limits<double>::max(),
                   std::numeric_limits<double>::max());
        }
        checked[key] = v;
        break;
    }
  }
  return RequestArgs(std::move(checked));
}

}  // namespace parallax::daemon
