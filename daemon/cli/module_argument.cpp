#include "daemon/cli/module_argument.h"

#include <fmt/format.h>

#include <exception>

#include "common/input_error.h"

namespace parallax::cli {

std::vector<int> parseModuleArgument(const std::string& text, size_t moduleCount) {
  std::vector<int> indices;
  if (text == "all") {
    for (size_t i = 0; i < moduleCount; ++i) indices.push_back(static_cast<int>(i));
    return indices;
  }
  int index = -1;
  try {
    size_t used = 0;
    index = std::stoi(text, &used);
    if (used != text.size()) index = -1;
  } catch (const std::exception&) {
    index = -1;
  }
  if (index < 0 || index >= static_cast<int>(moduleCount)) {
    throw InputError({"", "--module", 0},
                     fmt::format("must be all or 0..{}, got \"{}\"", moduleCount - 1, text));
  }
  return {index};
}

}  // namespace parallax::cli
