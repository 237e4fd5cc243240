#pragma once
// File access from a scene script: only through the API, only to files below the script's own
// folder (or the scene library's folder, for `require`). A script is untrusted content, so a
// path it names is rejected when it is absolute, contains "..", or resolves (symlinks followed)
// to somewhere outside the allowed folder.

#include <cstdint>
#include <string>

namespace parallax {

// Resolves `relative` (as written in the script) below `folder`. Throws std::runtime_error
// with a reason naming the path (the binding adds the script's name and line).
std::string resolvePathBelow(const std::string& folder, const std::string& relative);

// Reads a whole text file of at most `maxBytes` (scripts and modules are small; a bigger file
// is refused rather than read). Throws std::runtime_error naming the file.
std::string readSmallFile(const std::string& path, std::uintmax_t maxBytes);

}  // namespace parallax
