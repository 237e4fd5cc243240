#pragma once
// JSON files from disk: syntax errors become an InputError naming the file and the line. Only
// regular files up to `maxBytes` are read (common/regular_file.h): a folder, a FIFO or
// /dev/zero is refused before reading.

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>

namespace parallax {

constexpr size_t kMaxJsonFileBytes = size_t{256} << 20;  // decoded captures run to tens of MiB

nlohmann::json readJsonFile(const std::string& path, size_t maxBytes = kMaxJsonFileBytes);

}  // namespace parallax
