#include "calibration/display/json_fields.h"

#include <fmt/format.h>

#include <cmath>

#include "common/input_error.h"

namespace parallax::jsonfield {

void fail(const std::string& field, const std::string& reason) {
  throw InputError(InputLocation{"", field, 0}, reason);
}

std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

const json& member(const json& object, const std::string& key, const std::string& path) {
  if (!object.is_object()) fail(path, fmt::format("must be an object, got {}", object.type_name()));
  const auto it = object.find(key);
  if (it == object.end()) fail(join(path, key), "missing");
  return *it;
}

double number(const json& j, const std::string& field) {
  if (!j.is_number()) fail(field, fmt::format("must be a number, got {}", j.type_name()));
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail(field, "must be a finite number");
  return v;
}

long long integer(const json& j, const std::string& field, long long lo, long long hi) {
  if (!j.is_number_integer()) fail(field, fmt::format("must be an integer, got {}", j.type_name()));
  const long long v = j.get<long long>();
  if (v < lo || v > hi) fail(field, fmt::format("must be {}..{}, got {}", lo, hi, v));
  return v;
}

std::vector<double> numbers(const json& j, const std::string& field, size_t size) {
  if (!j.is_array() || j.size() != size) {
    fail(field, fmt::format("must be an array of {} numbers, got {}", size,
                            j.is_array() ? fmt::format("{} elements", j.size())
                                         : std::string(j.type_name())));
  }
  std::vector<double> out;
  for (size_t i = 0; i < size; ++i) out.push_back(number(j[i], fmt::format("{}[{}]", field, i)));
  return out;
}

const json& array(const json& j, const std::string& field, size_t maxSize) {
  if (!j.is_array()) fail(field, fmt::format("must be an array, got {}", j.type_name()));
  if (j.size() > maxSize) fail(field, fmt::format("at most {} entries", maxSize));
  return j;
}

void requireFormat(const json& document, const std::string& name, int version) {
  const json& format = member(document, "format");
  if (!format.is_string() || format.get<std::string>() != name) {
    fail("format", fmt::format("must be \"{}\", got {}", name, format.dump()));
  }
  const json& v = member(document, "version");
  if (!v.is_number_integer() || v.get<long long>() != version) {
    fail("version",
         fmt::format("unknown version {} (this build reads version {})", v.dump(), version));
  }
}

}  // namespace parallax::jsonfield
