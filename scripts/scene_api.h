#pragma once
// The scene API a script sees: the global table `px` (materials, primitives, meshes, model
// files, textures, lights, transforms, the world box, parameters) and the global table
// `params`. Every function is registered with its signature, a one-line description and an
// example, from which the API reference is generated (`parallax scene-api`, scripts/API.md).

#include <map>
#include <string>
#include <vector>

#include "tracer/model_animation.h"
#include "tracer/scene.h"

namespace parallax {

class ScriptSandbox;

// A number the script declares with px.param; `parallax render --set name=value` (and later
// the daemon's control socket) changes it; update(t, dt) reads it from `params`.
struct ScriptParameter {
  std::string name;
  double value = 0.0;
  double defaultValue = 0.0;
  double min = 0.0;
  double max = 0.0;
  std::string description;
};

// What the binding keeps for one Lua state.
struct SceneBuild {
  Scene scene;
  bool loading = true;  // geometry, materials and parameters can be added only while loading
  std::map<std::string, double> overrides;  // parameter values given before loading
  std::vector<ScriptParameter> parameters;
  std::vector<std::string> assets;     // files read through the API (canonical), for hot reload
  std::vector<ModelAnimation> models;  // per px.model: its animations (none for a still file)
  // Trusted folders a script may read below by prefix, e.g. "assimp:OBJ/spider.obj".
  std::map<std::string, std::string> assetRoots;
  // Set while a px function runs: a finalizer (__gc) the collector starts inside it must not
  // call back into the scene that the outer call holds references into.
  bool inCall = false;
};

// Installs `px` and `params` into the sandbox; `build` must outlive it.
void installSceneApi(ScriptSandbox& sandbox, SceneBuild* build);
// Copies the current parameter values into the script's `params` table.
void publishParameters(ScriptSandbox& sandbox, const SceneBuild& build);

struct SceneApiEntry {
  const char* name;
  const char* signature;
  const char* description;
  const char* example;
};
const std::vector<SceneApiEntry>& sceneApiReference();
// The reference as markdown (what `parallax scene-api` prints and scripts/API.md holds).
std::string sceneApiMarkdown();

}  // namespace parallax
