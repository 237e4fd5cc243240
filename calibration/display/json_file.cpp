#include "calibration/display/json_file.h"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "common/input_error.h"

namespace parallax {

using nlohmann::json;

json readJsonFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError({path, "", 0}, "cannot open the file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
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
