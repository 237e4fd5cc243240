#pragma once
// Where a `--scene` argument comes from: a built-in fixture by name, or a model file (OBJ,
// glTF, ... through assimp) lit by the paper's four directional lights.

#include <string>

#include "tracer/scene.h"

namespace parallax {

// Throws InputError for an unknown name or a file that cannot be loaded.
Scene resolveScene(const std::string& nameOrFile);

// Where Debian's assimp-testmodels puts its files (PARALLAX_ASSIMP_MODELS overrides).
std::string assimpTestModelsRoot();

}  // namespace parallax
