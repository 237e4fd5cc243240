#pragma once
// Reading the fields of untrusted JSON (captures, camera files, observations, display models):
// every failure is an InputError naming the field as a dotted path ("sensor.gamma",
// "poses[2].centre"); the caller's catch adds the file.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace parallax::jsonfield {

using nlohmann::json;

[[noreturn]] void fail(const std::string& field, const std::string& reason);

// "path.key", or "key" at the top level.
std::string join(const std::string& path, const std::string& key);

// object[key]; `path` names the object in the error ("" at the top level).
const json& member(const json& object, const std::string& key, const std::string& path = "");

double number(const json& j, const std::string& field);  // finite
long long integer(const json& j, const std::string& field, long long lo, long long hi);
std::vector<double> numbers(const json& j, const std::string& field,
                            size_t size);  // exactly `size`, finite
const json& array(const json& j, const std::string& field, size_t maxSize);

// The document's "format" is `name` and its "version" is `version` (the files this build reads).
void requireFormat(const json& document, const std::string& name, int version);

}  // namespace parallax::jsonfield
