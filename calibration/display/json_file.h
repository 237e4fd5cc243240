#pragma once
// JSON files from disk: syntax errors become an InputError naming the file and the line.

#include <nlohmann/json.hpp>
#include <string>

namespace parallax {

nlohmann::json readJsonFile(const std::string& path);

}  // namespace parallax
