#include "calibration/display/json_file.h"

#include <algorithm>

#include "common/input_error.h"
#include "common/regular_file.h"

namespace parallax {

using nlohmann::json;

json readJsonFile(const std::string& path, size_t maxBytes) {
  const std::string text = readRegularFile(path, maxBytes);
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    const size_t end = std::min(text.size(), static_cast<size_t>(e.byte));
    const int line =
        1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(end), '\n'));
    std::string reason = e.what();
    const size_t colon = reason.find(": ");
    if (colon != std::string::npos) reason = reason.substr(colon + 2);
    throw InputError({path, "", line}, "not valid JSON: " + reason);
  }
}

}  // namespace parallax
