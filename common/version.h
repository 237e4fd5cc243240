#pragma once
// The version every program's --version prints (common/version.cpp.in, filled in when CMake
// configures: the project version, and `git describe` when the sources are a git checkout).

#include <string>

namespace parallax {

std::string parallaxVersion();      // "0.1.0"
std::string parallaxGitDescribe();  // "v0.1.0-12-gabcdef-dirty", or "" outside git

}  // namespace parallax
