#include "common/width_height.h"

#include <fmt/format.h>

#include <regex>

#include "common/input_error.h"

namespace parallax {

WidthHeight parseWidthHeight(std::string_view text, const std::string& field) {
  static const std::regex kPattern(R"((\d{1,5})x(\d{1,5}))");
  const std::string s(text);
  std::smatch match;
  if (!std::regex_match(s, match, kPattern)) {
    throw InputError({"", field, 0},
                     fmt::format("expected WIDTHxHEIGHT such as 1024x768, got \"{}\"", s));
  }
  return {std::stoi(match[1]), std::stoi(match[2])};
}

}  // namespace parallax
