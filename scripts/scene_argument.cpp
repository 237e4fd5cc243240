#include "scripts/scene_argument.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>

#include "common/input_error.h"
#include "scripts/scene_script.h"
#include "tracer/scene_source.h"

namespace parallax {

bool isSceneScript(const std::string& nameOrFile) {
  return nameOrFile.size() > 4 && nameOrFile.compare(nameOrFile.size() - 4, 4, ".lua") == 0;
}

std::map<std::string, double> parseParameterSettings(const std::vector<std::string>& settings) {
  std::map<std::string, double> values;
  for (const std::string& s : settings) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InputError({"", "--set", 0}, fmt::format("\"{}\": expected name=value", s));
    }
    const std::string name = s.substr(0, eq), text = s.substr(eq + 1);
    double value = 0.0;
    size_t used = 0;
    try {
      value = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size() || !std::isfinite(value)) {
      throw InputError({"", "--set " + name, 0},
                       fmt::format("\"{}\" is not a finite number", text));
    }
    values[name] = value;
  }
  return values;
}

std::string librarySceneScript(const std::string& name) {
  if (name.empty() ||
      name.find_first_not_of("abcdefghijklmnopqrstuvwxyz_0123456789") != std::string::npos) {
    return "";
  }
  const std::filesystem::path script =
      std::filesystem::path(ScriptOptions::defaultSceneLibrary()) / (name + ".lua");
  return std::filesystem::is_regular_file(script) ? script.string() : "";
}

Scene loadSceneArgument(const std::string& nameOrFile, const std::vector<std::string>& settings,
                        double time) {
  if (!std::isfinite(time)) throw InputError({"", "--time", 0}, "must be finite");
  // A bare name of the scene library (cornell, shapes, statue, orbit) means its script: the
  // library is the source of truth; the tracer's C++ fixtures remain as the test oracles it is
  // checked against.
  if (const std::string script = librarySceneScript(nameOrFile); !script.empty()) {
    return loadSceneArgument(script, settings, time);
  }
  if (!isSceneScript(nameOrFile)) {
    if (!settings.empty())
      throw InputError({"", "--set", 0}, "parameters apply only to scene scripts (*.lua)");
    return resolveScene(nameOrFile);
  }
  ScriptOptions options;
  options.parameters = parseParameterSettings(settings);
  std::unique_ptr<SceneScript> script = SceneScript::loadFile(nameOrFile, options);
  script->setTime(time);
  return script->scene();
}

}  // namespace parallax
