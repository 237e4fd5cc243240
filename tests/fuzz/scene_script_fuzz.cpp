// Hostile scene scripts: any bytes must build a scene or raise an InputError (with the limits
// of the sandbox holding), never crash, hang or leak out of the sandbox.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "common/input_error.h"
#include "scripts/scene_script.h"

namespace {

const std::string& scratchFolder() {
  static const std::string folder = [] {
    const std::filesystem::path p =
        std::filesystem::temp_directory_path() / "parallax_fuzz_scene_script";
    std::filesystem::create_directories(p);
    return p.string();
  }();
  return folder;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string source(reinterpret_cast<const char*>(data), size);
  parallax::ScriptOptions options;
  // Small limits keep every input to milliseconds; they are the same code paths as the defaults.
  options.limits.loadInstructions = 300'000;
  options.limits.updateInstructions = 100'000;
  options.limits.memoryBytes = std::size_t{8} << 20;
  options.limits.loadAllocationBytes = std::size_t{64} << 20;
  options.limits.updateAllocationBytes = std::size_t{16} << 20;
  options.limits.maxTriangles = 50'000;
  options.limits.maxTexturePixels = 1 << 16;
  options.quiet = true;
  try {
    auto script = parallax::SceneScript::loadSource(source, "fuzz.lua", scratchFolder(), options);
    script->scene().validate();
    if (script->animated()) {
      for (double t : {0.5, 1.0, 0.25}) {
        try {
          script->setTime(t);
        } catch (const parallax::InputError&) {
        }
        script->scene().validate();
      }
    }
  } catch (const parallax::InputError&) {
  }
  return 0;
}
