#pragma once
// Reading a script's arguments and pushing results, for the scene API binding.
//
// Lua reports errors with longjmp, which must never unwind through C++ frames that own
// objects. So the readers here use only the raw, non-raising parts of the Lua API and throw
// ScriptArgumentError instead; the binding's dispatcher (scene_api.cpp) catches it once all C++
// objects are gone and raises the Lua error there, with the script's line.

#include <Eigen/Geometry>
#include <initializer_list>
#include <stdexcept>
#include <string>

#include "tracer/scene.h"

struct lua_State;

namespace parallax::lua {

class ScriptArgumentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

double toNumber(lua_State* L, int index, const std::string& what);
long toInteger(lua_State* L, int index, const std::string& what, long min, long max);
std::string toString(lua_State* L, int index, const std::string& what);
bool toBoolean(lua_State* L, int index, const std::string& what);
Eigen::Vector3d toVector3(lua_State* L, int index, const std::string& what);  // {x, y, z}
Rgb toColor(lua_State* L, int index, const std::string& what);  // {r, g, b}, each finite and >= 0

// An options table such as {size = {1, 2, 3}, material = m}. Every key must be one the
// function knows: a misspelt field is an error, not silently ignored.
class Options {
 public:
  Options(lua_State* L, int index, const std::string& function,
          std::initializer_list<const char*> known);
  bool has(const char* key) const;
  double number(const char* key, double fallback) const;
  double number(const char* key) const;  // required
  long integer(const char* key, long fallback, long min, long max) const;
  std::string string(const char* key, const std::string& fallback) const;
  bool boolean(const char* key, bool fallback) const;
  Eigen::Vector3d vector3(const char* key, const Eigen::Vector3d& fallback) const;
  Eigen::Vector3d vector3(const char* key) const;  // required
  Rgb color(const char* key, const Rgb& fallback) const;
  // Pushes the field's raw value (nil when absent) and returns its absolute stack index; the
  // caller pops it.
  int push(const char* key) const;

 private:
  lua_State* L_;
  int index_;
};

// Transforms are userdata holding an affine map, composed with `*` (left applies last, as in
// Eigen): px.translate(...) * px.rotate_y(...).
void registerTransformType(lua_State* L);
void pushTransform(lua_State* L, const Eigen::Affine3d& transform);
Eigen::Affine3d toTransform(lua_State* L, int index, const std::string& what);

// Handles to what the script added (a material, an object, a light, a texture, a model file's
// animations): typed
// userdata, so passing a light where a material belongs is a clear error.
enum class HandleKind : int { kMaterial, kObject, kLight, kTexture, kModel };
void registerHandleType(lua_State* L);
void pushHandle(lua_State* L, HandleKind kind, int index);
int toHandle(lua_State* L, int index, HandleKind kind, const std::string& what);

}  // namespace parallax::lua
