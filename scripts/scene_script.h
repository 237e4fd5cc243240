#pragma once
// One loaded version of a scene script: its sandbox, the Scene it built, its parameters and
// the files it read. Loading runs the script once (it builds the scene through `px`); a
// script that defines update(t, dt) is animated and is advanced with setTime().

#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "scripts/scene_api.h"
#include "scripts/script_sandbox.h"

namespace parallax {

struct ScriptOptions {
  ScriptLimits limits;
  // Where `require` finds the shared helpers (scripts/scenes of the source tree by default).
  std::string libraryRoot = defaultSceneLibrary();
  // Parameter values to use instead of the script's defaults (render --set name=value).
  std::map<std::string, double> parameters;
  // A value for a parameter the script does not declare is an error, except when a reload
  // carries the values over to a version that dropped one.
  bool strictParameters = true;
  // Folders besides the script's own that its asset paths may name by prefix ("assimp:" is
  // Debian's assimp-testmodels); paths stay confined below each.
  std::map<std::string, std::string> assetRoots = defaultAssetRoots();
  bool quiet = false;  // silence the script's print()

  static std::string defaultSceneLibrary();
  static std::map<std::string, std::string> defaultAssetRoots();
  void validate() const;
};

class SceneScript {
 public:
  // Both throw InputError with the script's name and line (or the field of a bad option).
  static std::unique_ptr<SceneScript> loadFile(const std::string& path,
                                               const ScriptOptions& options);
  // `folder` is what the script may read files below (and require from).
  static std::unique_ptr<SceneScript> loadSource(const std::string& source, const std::string& name,
                                                 const std::string& folder,
                                                 const ScriptOptions& options);
  ~SceneScript();

  const Scene& scene() const { return build_.scene; }
  const std::string& name() const { return name_; }
  bool animated() const { return animated_; }
  double time() const { return time_; }

  // Calls update(t, t − previous t). On an error (InputError with the line) the scene keeps
  // its last good state: transforms, lights, materials and background are restored.
  void setTime(double t);

  const std::vector<ScriptParameter>& parameters() const { return build_.parameters; }
  // An animated script sees the new value in its next update; a static one is built again
  // by the caller (ScriptedScene). Throws InputError for an unknown name or a value out of range.
  void setParameter(const std::string& name, double value);

  // The script, the modules it required and the assets it read (canonical paths).
  std::vector<std::string> files() const;
  std::size_t memoryUsed() const { return sandbox_->memoryUsed(); }
  long instructionsUsed() const { return sandbox_->instructionsUsed(); }

 private:
  SceneScript() = default;
  void load(const std::string& source, const ScriptOptions& options);

  std::string name_;
  std::string path_;  // empty for loadSource
  std::string sandboxFolder_;
  SceneBuild build_;  // before sandbox_: the Lua state (and its finalizers) goes first
  std::unique_ptr<ScriptSandbox> sandbox_;
  bool animated_ = false;
  double time_ = 0.0;
};

}  // namespace parallax
