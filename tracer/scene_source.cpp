#include "tracer/scene_source.h"

#include <cstdlib>
#include <filesystem>

#include "common/input_error.h"
#include "tracer/model_loader.h"
#include "tracer/scene_fixtures.h"

namespace parallax {

std::string assimpTestModelsRoot() {
  if (const char* env = std::getenv("PARALLAX_ASSIMP_MODELS")) return env;
  return "/usr/share/assimp/models";
}

Scene resolveScene(const std::string& nameOrFile) {
  if (isBuiltInScene(nameOrFile)) return makeBuiltInScene(nameOrFile, assimpTestModelsRoot());
  if (!std::filesystem::exists(nameOrFile)) {
    throw InputError({"", "--scene", 0},
                     "\"" + nameOrFile +
                         "\" is neither a built-in scene (cornell, shapes, statue, xyz) "
                         "nor an existing file");
  }
  return loadModelScene(nameOrFile);
}

}  // namespace parallax
