// px.animations and px.set_animation: a model file's node and skeletal animations, listed and
// posed from a script (the evaluation itself is tracer/model_animation.h).

#include <fmt/format.h>

#include <cmath>
#include <lua.hpp>

#include "scripts/lua_values.h"
#include "scripts/scene_api_functions.h"

namespace parallax::scene_api_detail {
namespace {

using lua::HandleKind;
using lua::ScriptArgumentError;

ModelAnimation& modelOf(lua_State* L, SceneBuild& b) {
  return b.models.at(static_cast<size_t>(lua::toHandle(L, 1, HandleKind::kModel, "model")));
}

// The clip a script names: by its name, or by its 1-based place in px.animations' list.
int clipOf(lua_State* L, const ModelAnimation& model) {
  if (model.clips.empty())
    throw ScriptArgumentError(fmt::format("\"{}\" has no animations", model.file));
  if (lua_type(L, 2) == LUA_TNUMBER) {
    return static_cast<int>(
        lua::toInteger(L, 2, "animation", 1, static_cast<long>(model.clips.size())) - 1);
  }
  const std::string name = lua::toString(L, 2, "animation (a name or a number)");
  const int clip = model.findClip(name);
  if (clip >= 0) return clip;
  std::string known;
  for (const AnimationClip& c : model.clips)
    known += (known.empty() ? "\"" : ", \"") + c.name + "\"";
  throw ScriptArgumentError(
      fmt::format("\"{}\" has no animation \"{}\" (it has: {})", model.file, name, known));
}

}  // namespace

int apiAnimations(lua_State* L, SceneBuild& b) {
  const ModelAnimation& model = modelOf(L, b);
  lua_createtable(L, static_cast<int>(model.clips.size()), 0);
  for (size_t i = 0; i < model.clips.size(); ++i) {
    lua_createtable(L, 0, 2);
    lua_pushstring(L, model.clips[i].name.c_str());
    lua_setfield(L, -2, "name");
    lua_pushnumber(L, model.clips[i].duration);
    lua_setfield(L, -2, "duration");
    lua_rawseti(L, -2, static_cast<lua_Integer>(i + 1));
  }
  return 1;
}

int apiSetAnimation(lua_State* L, SceneBuild& b) {
  ModelAnimation& model = modelOf(L, b);
  const int clip = clipOf(L, model);
  const double seconds = lua::toNumber(L, 3, "time (seconds)");
  const bool placed = !lua_isnone(L, 4) && !lua_isnil(L, 4);
  if (placed) model.placement = lua::toTransform(L, 4, "transform");
  model.pose(clip, model.clipTime(clip, seconds), &b.scene);
  if (b.loading) return 0;  // posed while building: not moving
  // Every part any clip moves: switching clips moves what the new one leaves at rest.
  for (const AnimationClip& c : model.clips)
    b.scene.movedInstances.insert(c.movingInstances.begin(), c.movingInstances.end());
  if (placed) {
    for (const RigidPart& part : model.rigidParts) b.scene.movedInstances.insert(part.instance);
    for (const SkinnedPart& part : model.skinnedParts)
      b.scene.movedInstances.insert(part.instances.begin(), part.instances.end());
  }
  return 0;
}

}  // namespace parallax::scene_api_detail
