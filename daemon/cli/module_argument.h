#pragma once
// `--module all|N` of the offline subcommands (render, raytex): every module of the display, or
// one by its index.

#include <string>
#include <vector>

namespace parallax::cli {

// The module indices `text` names on a display of `moduleCount` modules. Throws InputError
// naming --module and quoting `text` for anything but "all" or an index in range.
std::vector<int> parseModuleArgument(const std::string& text, size_t moduleCount);

}  // namespace parallax::cli
