#include "calibration/display/json_file.h"

#include <algorithm>

#include "common/input_error.h"
#include "common/regular_file.h"

namespace parallax {

using nlohmann::json;

namespace {

// The 1-based line of byte `at` of `text`.
int lineOf(const std::string& text, size_t at) {
  const size_t end = std::min(text.size(), at);
  return 1 +
         static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(end), '\n'));
}

}  // namespace

json readJsonFile(const std::string& path, size_t maxBytes) {
  const std::string text = readRegularFile(path, maxBytes);
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    const int line = lineOf(text, static_cast<size_t>(e.byte));
    std::string reason = e.what();
    const size_t colon = reason.find(": ");
    if (colon != std::string::npos) reason = reason.substr(colon + 2);
    throw InputError({path, "", line}, "not valid JSON: " + reason);
  } catch (const json::out_of_range& e) {
    // A number beyond a double ("1e400") is refused while parsing, without a byte position:
    // its line is where its text first appears.
    std::string reason = e.what();
    const size_t colon = reason.find("] ");
    if (colon != std::string::npos) reason = reason.substr(colon + 2);
    int line = 0;
    const size_t open = reason.find('\''), close = reason.rfind('\'');
    if (open != std::string::npos && close > open + 1) {
      const size_t at = text.find(reason.substr(open + 1, close - open - 1));
      if (at != std::string::npos) line = lineOf(text, at);
    }
    throw InputError({path, "", line}, "not valid JSON: " + reason);
  }
}

}  // namespace parallax
