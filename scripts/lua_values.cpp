#include "scripts/lua_values.h"

#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <lua.hpp>
#include <new>

namespace parallax::lua {
namespace {

const char* const kTransformType = "parallax.transform";
const char* const kHandleType = "parallax.handle";
const char* const kHandleNames[] = {"material", "object", "light", "texture", "model"};

// Userdata is only aligned for doubles, Eigen's fixed-size matrices want 16 bytes: keep the
// plain 4×4 column-major numbers and copy them in and out.
struct TransformData {
  double m[16];
};

struct HandleData {
  HandleKind kind;
  int index;
};

std::string typeName(lua_State* L, int index) { return luaL_typename(L, index); }

// Raw field read: never calls metamethods, so never runs script code or raises.
int rawField(lua_State* L, int table, const char* key) {
  lua_pushstring(L, key);
  return lua_rawget(L, table);
}

std::string describeHandle(lua_State* L, int index) {
  if (auto* h = static_cast<HandleData*>(luaL_testudata(L, index, kHandleType)))
    return kHandleNames[static_cast<int>(h->kind)];
  if (luaL_testudata(L, index, kTransformType) != nullptr) return "transform";
  return typeName(L, index);
}

template <int (*F)(lua_State*)>
int guardedMeta(lua_State* L) {
  try {
    return F(L);
  } catch (const std::exception& e) {
    lua_pushstring(L, e.what());
  }
  luaL_where(L, 1);
  lua_insert(L, -2);
  lua_concat(L, 2);
  return lua_error(L);
}

int transformMul(lua_State* L) {
  const Eigen::Affine3d product = toTransform(L, 1, "transform * transform: left") *
                                  toTransform(L, 2, "transform * transform: right");
  pushTransform(L, product);
  return 1;
}

int transformToString(lua_State* L) {
  const Eigen::Affine3d t = toTransform(L, 1, "transform");
  const Eigen::Vector3d p = t.translation();
  const std::string text =
      fmt::format("transform(translation {:.6g} {:.6g} {:.6g})", p.x(), p.y(), p.z());
  lua_pushlstring(L, text.data(), text.size());
  return 1;
}

int handleToString(lua_State* L) {
  auto* h = static_cast<HandleData*>(luaL_testudata(L, 1, kHandleType));
  if (h == nullptr) return 0;
  lua_pushfstring(L, "%s %d", kHandleNames[static_cast<int>(h->kind)], h->index);
  return 1;
}

int handleEq(lua_State* L) {
  auto* a = static_cast<HandleData*>(luaL_testudata(L, 1, kHandleType));
  auto* b = static_cast<HandleData*>(luaL_testudata(L, 2, kHandleType));
  lua_pushboolean(L, a != nullptr && b != nullptr && a->kind == b->kind && a->index == b->index);
  return 1;
}

}  // namespace

double toNumber(lua_State* L, int index, const std::string& what) {
  int isNumber = 0;
  const double value = lua_tonumberx(L, index, &isNumber);
  if (lua_type(L, index) != LUA_TNUMBER || !isNumber) {
    throw ScriptArgumentError(
        fmt::format("{}: expected a number, got {}", what, typeName(L, index)));
  }
  if (!std::isfinite(value))
    throw ScriptArgumentError(fmt::format("{}: must be finite, got {}", what, value));
  return value;
}

long toInteger(lua_State* L, int index, const std::string& what, long min, long max) {
  const double value = toNumber(L, index, what);
  if (value != std::floor(value))
    throw ScriptArgumentError(fmt::format("{}: expected a whole number, got {}", what, value));
  if (value < static_cast<double>(min) || value > static_cast<double>(max)) {
    throw ScriptArgumentError(
        fmt::format("{}: must be in [{}, {}], got {}", what, min, max, value));
  }
  return static_cast<long>(value);
}

std::string toString(lua_State* L, int index, const std::string& what) {
  if (lua_type(L, index) != LUA_TSTRING) {
    throw ScriptArgumentError(
        fmt::format("{}: expected a string, got {}", what, typeName(L, index)));
  }
  size_t length = 0;
  const char* text = lua_tolstring(L, index, &length);
  if (length > 4096)
    throw ScriptArgumentError(fmt::format("{}: string longer than 4096 bytes", what));
  return std::string(text, length);
}

bool toBoolean(lua_State* L, int index, const std::string& what) {
  if (lua_type(L, index) != LUA_TBOOLEAN) {
    throw ScriptArgumentError(
        fmt::format("{}: expected true or false, got {}", what, typeName(L, index)));
  }
  return lua_toboolean(L, index) != 0;
}

Eigen::Vector3d toVector3(lua_State* L, int index, const std::string& what) {
  index = lua_absindex(L, index);
  if (lua_type(L, index) != LUA_TTABLE || lua_rawlen(L, index) != 3) {
    throw ScriptArgumentError(
        fmt::format("{}: expected a table of three numbers like {{x, y, z}}, got {}", what,
                    typeName(L, index)));
  }
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    lua_rawgeti(L, index, i + 1);
    v[i] = toNumber(L, -1, fmt::format("{}[{}]", what, i + 1));
    lua_pop(L, 1);
  }
  return v;
}

Rgb toColor(lua_State* L, int index, const std::string& what) {
  const Eigen::Vector3d c = toVector3(L, index, what);
  if ((c.array() < 0.0).any() || (c.array() > 1e6).any()) {
    throw ScriptArgumentError(
        fmt::format("{}: colour components must be in [0, 1e6], got {{{}, {}, {}}}", what, c.x(),
                    c.y(), c.z()));
  }
  return c.cast<float>();
}

Options::Options(lua_State* L, int index, const std::string& function,
                 std::initializer_list<const char*> known)
    : L_(L), index_(lua_absindex(L, index)) {
  if (lua_type(L, index_) != LUA_TTABLE) {
    throw ScriptArgumentError(fmt::format("{}: expected a table of options {{...}}, got {}",
                                          function, typeName(L, index_)));
  }
  lua_pushnil(L);
  while (lua_next(L, index_) != 0) {
    bool ok = false;
    if (lua_type(L, -2) == LUA_TSTRING) {
      const char* key = lua_tostring(L, -2);
      for (const char* k : known) ok = ok || std::strcmp(k, key) == 0;
    }
    if (!ok) {
      std::string list;
      for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      const std::string key = lua_type(L, -2) == LUA_TSTRING
                                  ? fmt::format("\"{}\"", lua_tostring(L, -2))
                                  : fmt::format("a {} key", typeName(L, -2));
      throw ScriptArgumentError(
          fmt::format("{}: unknown field {} (known: {})", function, key, list));
    }
    lua_pop(L, 1);
  }
}

int Options::push(const char* key) const {
  rawField(L_, index_, key);
  return lua_gettop(L_);
}

bool Options::has(const char* key) const {
  const bool present = rawField(L_, index_, key) != LUA_TNIL;
  lua_pop(L_, 1);
  return present;
}

double Options::number(const char* key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

double Options::number(const char* key) const {
  const int i = push(key);
  if (lua_isnil(L_, i)) throw ScriptArgumentError(std::string(key) + ": required");
  const double v = toNumber(L_, i, key);
  lua_pop(L_, 1);
  return v;
}

long Options::integer(const char* key, long fallback, long min, long max) const {
  const int i = push(key);
  const long v = lua_isnil(L_, i) ? fallback : toInteger(L_, i, key, min, max);
  lua_pop(L_, 1);
  return v;
}

std::string Options::string(const char* key, const std::string& fallback) const {
  const int i = push(key);
  std::string v = lua_isnil(L_, i) ? fallback : toString(L_, i, key);
  lua_pop(L_, 1);
  return v;
}

bool Options::boolean(const char* key, bool fallback) const {
  const int i = push(key);
  const bool v = lua_isnil(L_, i) ? fallback : toBoolean(L_, i, key);
  lua_pop(L_, 1);
  return v;
}

Eigen::Vector3d Options::vector3(const char* key, const Eigen::Vector3d& fallback) const {
  return has(key) ? vector3(key) : fallback;
}

Eigen::Vector3d Options::vector3(const char* key) const {
  const int i = push(key);
  if (lua_isnil(L_, i)) throw ScriptArgumentError(std::string(key) + ": required");
  const Eigen::Vector3d v = toVector3(L_, i, key);
  lua_pop(L_, 1);
  return v;
}

Rgb Options::color(const char* key, const Rgb& fallback) const {
  const int i = push(key);
  const Rgb v = lua_isnil(L_, i) ? fallback : toColor(L_, i, key);
  lua_pop(L_, 1);
  return v;
}

void registerTransformType(lua_State* L) {
  luaL_newmetatable(L, kTransformType);
  lua_pushcfunction(L, &guardedMeta<transformMul>);
  lua_setfield(L, -2, "__mul");
  lua_pushcfunction(L, &guardedMeta<transformToString>);
  lua_setfield(L, -2, "__tostring");
  lua_pushboolean(L, 0);
  lua_setfield(L, -2, "__metatable");  // getmetatable() shows nothing to change
  lua_pop(L, 1);
}

void pushTransform(lua_State* L, const Eigen::Affine3d& transform) {
  auto* data = static_cast<TransformData*>(lua_newuserdatauv(L, sizeof(TransformData), 0));
  std::memcpy(data->m, transform.matrix().data(), sizeof(data->m));
  luaL_setmetatable(L, kTransformType);
}

Eigen::Affine3d toTransform(lua_State* L, int index, const std::string& what) {
  auto* data = static_cast<TransformData*>(luaL_testudata(L, index, kTransformType));
  if (data == nullptr) {
    throw ScriptArgumentError(
        fmt::format("{}: expected a transform (px.translate, px.rotate_y, ...), got {}", what,
                    describeHandle(L, index)));
  }
  Eigen::Affine3d t;
  std::memcpy(t.matrix().data(), data->m, sizeof(data->m));
  return t;
}

void registerHandleType(lua_State* L) {
  luaL_newmetatable(L, kHandleType);
  lua_pushcfunction(L, &handleToString);
  lua_setfield(L, -2, "__tostring");
  lua_pushcfunction(L, &handleEq);
  lua_setfield(L, -2, "__eq");
  lua_pushboolean(L, 0);
  lua_setfield(L, -2, "__metatable");
  lua_pop(L, 1);
}

void pushHandle(lua_State* L, HandleKind kind, int index) {
  auto* data = static_cast<HandleData*>(lua_newuserdatauv(L, sizeof(HandleData), 0));
  data->kind = kind;
  data->index = index;
  luaL_setmetatable(L, kHandleType);
}

int toHandle(lua_State* L, int index, HandleKind kind, const std::string& what) {
  auto* data = static_cast<HandleData*>(luaL_testudata(L, index, kHandleType));
  if (data == nullptr || data->kind != kind) {
    throw ScriptArgumentError(fmt::format("{}: expected a {}, got {}", what,
                                          kHandleNames[static_cast<int>(kind)],
                                          describeHandle(L, index)));
  }
  return data->index;
}

}  // namespace parallax::lua
