#pragma once
// The `--scene` argument of `parallax render` (and later the daemon): a scene script (*.lua)
// with `--set name=value` parameters and `--time T`, or whatever the tracer resolves (a
// built-in fixture name or a model file).

#include <map>
#include <string>
#include <vector>

#include "tracer/scene.h"

namespace parallax {

bool isSceneScript(const std::string& nameOrFile);

// "name=value" settings → values; throws InputError naming the bad setting.
std::map<std::string, double> parseParameterSettings(const std::vector<std::string>& settings);

// The scene library's script for a bare name ("cornell" → <library>/cornell.lua), or "".
std::string librarySceneScript(const std::string& name);

// Builds the scene the argument names at animation time `time` (seconds). A bare library name
// loads its script. Throws InputError
// (script name and line for script errors; --set / --time for bad options).
Scene loadSceneArgument(const std::string& nameOrFile, const std::vector<std::string>& settings,
                        double time);

}  // namespace parallax
