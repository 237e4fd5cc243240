#include "common/input_error.h"
#include "tracer/scene_fixtures.h"

namespace parallax {

Scene makeStatueScene(const std::string&) {
  throw InputError({"", "--scene", 0}, "statue: model loading is not built yet");
}

}  // namespace parallax
