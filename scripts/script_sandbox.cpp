#include "scripts/script_sandbox.h"

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <lua.hpp>
#include <stdexcept>

#include "scripts/script_paths.h"

namespace parallax {
namespace {

// The count hook runs every kHookInterval VM instructions: rare enough to cost nothing
// measurable, frequent enough that a spent budget stops a loop within microseconds.
constexpr int kHookInterval = 1000;
const char* const kLoadedKey = "parallax.required";  // registry: module name -> value
const char* const kLoadingSentinel = "parallax.loading";
const char* const kRandomSeedKey = "parallax.randomseed";  // registry: the original randomseed

bool validModuleName(const char* name, std::size_t length) {
  if (length == 0 || length > 128 || name[0] == '.' || name[length - 1] == '.') return false;
  for (std::size_t i = 0; i < length; ++i) {
    const char c = name[i];
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || (c == '.' && name[i + 1] != '.');
    if (!ok) return false;
  }
  return true;
}

// The end of a checking wrapper: calls the library function it wraps (its upvalue 1) with the
// wrapper's arguments and returns what that returns.
int callWrapped(lua_State* L) {
  lua_pushvalue(L, lua_upvalueindex(1));
  lua_insert(L, 1);
  lua_call(L, lua_gettop(L) - 1, LUA_MULTRET);
  return lua_gettop(L);
}

}  // namespace

void ScriptLimits::validate() const {
  auto positive = [](bool ok, const char* field) {
    if (!ok) throw InputError({"", field, 0}, "must be positive");
  };
  positive(loadInstructions > 0, "limits.loadInstructions");
  positive(updateInstructions > 0, "limits.updateInstructions");
  positive(memoryBytes >= (std::size_t{1} << 20), "limits.memoryBytes (at least 1 MiB)");
  positive(loadAllocationBytes >= memoryBytes, "limits.loadAllocationBytes (at least memoryBytes)");
  positive(updateAllocationBytes > 0, "limits.updateAllocationBytes");
  positive(maxTriangles > 0, "limits.maxTriangles");
  positive(maxInstances > 0, "limits.maxInstances");
  positive(maxTexturePixels > 0, "limits.maxTexturePixels");
  positive(maxSourceBytes > 0, "limits.maxSourceBytes");
}

ScriptSandbox::ScriptSandbox(const ScriptLimits& limits, std::string folder,
                             std::string libraryRoot)
    : limits_(limits), folder_(std::move(folder)), libraryRoot_(std::move(libraryRoot)) {
  limits_.validate();
  allocationBudget_ = limits_.loadAllocationBytes;  // for setting up the state
  L_ = lua_newstate(&ScriptSandbox::allocate, this);
  if (L_ == nullptr) throw std::bad_alloc();
  *static_cast<ScriptSandbox**>(lua_getextraspace(L_)) = this;
  // Opening the libraries allocates, so it runs protected like everything else.
  lua_pushcfunction(L_, &ScriptSandbox::openSafeLibraries);
  if (lua_pcall(L_, 0, 0, 0) != LUA_OK) {
    const std::string message = lua_tostring(L_, -1) ? lua_tostring(L_, -1) : "?";
    lua_close(L_);
    throw std::runtime_error("cannot set up the Lua sandbox: " + message);
  }
}

ScriptSandbox::~ScriptSandbox() {
  // lua_close runs the script's finalizers (__gc): give them a fresh, bounded budget.
  startBudget(limits_.updateInstructions, limits_.updateAllocationBytes);
  lua_close(L_);
}

ScriptSandbox& ScriptSandbox::of(lua_State* L) {
  return **static_cast<ScriptSandbox**>(lua_getextraspace(L));
}

void* ScriptSandbox::allocate(void* ud, void* ptr, std::size_t osize, std::size_t nsize) {
  auto* self = static_cast<ScriptSandbox*>(ud);
  const std::size_t old = ptr != nullptr ? osize : 0;  // with ptr == NULL, osize is a type tag
  if (nsize == 0) {
    std::free(ptr);
    self->memoryUsed_ -= old;
    return nullptr;
  }
  // Only growth can be refused: Lua relies on shrinking never failing.
  if (nsize > old) {
    if (self->memoryUsed_ - old + nsize > self->limits_.memoryBytes) {
      self->memoryCapHit_ = true;
      self->recordWhere();
      return nullptr;
    }
    self->allocated_ += nsize;
    if (self->allocated_ > self->allocationBudget_) {
      if (!self->allocationBudgetHit_) self->recordWhere();
      self->allocationBudgetHit_ = true;
      return nullptr;
    }
  }
  void* block = std::realloc(ptr, nsize);
  if (block == nullptr) return nullptr;
  self->memoryUsed_ = self->memoryUsed_ - old + nsize;
  return block;
}

void ScriptSandbox::recordWhere() {
  // Called from the allocator when it refuses a block: only reads the call chain (getinfo
  // with "Sl" allocates nothing) to name the line that asked for the memory.
  if (L_ == nullptr) return;
  lua_Debug ar;
  for (int level = 0; level < 8 && lua_getstack(L_, level, &ar); ++level) {
    if (lua_getinfo(L_, "Sl", &ar) && ar.currentline > 0) {
      std::snprintf(lastSource_, sizeof(lastSource_), "%s", ar.short_src);
      lastLine_ = ar.currentline;
      return;
    }
  }
}

void ScriptSandbox::countHook(lua_State* L, lua_Debug* ar) {
  ScriptSandbox& self = of(L);
  lua_getinfo(L, "Sl", ar);
  std::snprintf(self.lastSource_, sizeof(self.lastSource_), "%s", ar->short_src);
  self.lastLine_ = ar->currentline;
  self.instructions_ += self.budgetSpent_ ? 1 : kHookInterval;
  if (self.instructions_ <= self.budget_) return;
  // From now on every instruction fails, so a script cannot catch the error with pcall and
  // carry on: the next instruction outside the pcall fails again.
  if (!self.budgetSpent_) {
    self.budgetSpent_ = true;
    lua_sethook(L, &ScriptSandbox::countHook, LUA_MASKCOUNT, 1);
  }
  lua_pushfstring(L, "%s:%d: instruction budget of %I exceeded (an endless loop?)", ar->short_src,
                  ar->currentline, static_cast<lua_Integer>(self.budget_));
  lua_error(L);
}

int ScriptSandbox::openSafeLibraries(lua_State* L) {
  const luaL_Reg libraries[] = {
      {LUA_GNAME, luaopen_base},        {LUA_TABLIBNAME, luaopen_table},
      {LUA_STRLIBNAME, luaopen_string}, {LUA_MATHLIBNAME, luaopen_math},
      {LUA_UTF8LIBNAME, luaopen_utf8},  {LUA_COLIBNAME, luaopen_coroutine}};
  for (const luaL_Reg& lib : libraries) {
    luaL_requiref(L, lib.name, lib.func, 1);
    lua_pop(L, 1);
  }
  // The base library's ways to reach files, the collector and binary chunks go; load, print
  // and require are replaced by sandboxed versions.
  for (const char* name : {"dofile", "loadfile", "collectgarbage"}) {
    lua_pushnil(L);
    lua_setglobal(L, name);
  }
  lua_pushcfunction(L, &ScriptSandbox::luaLoad);
  lua_setglobal(L, "load");
  lua_pushcfunction(L, &ScriptSandbox::luaPrint);
  lua_setglobal(L, "print");
  lua_pushcfunction(L, &ScriptSandbox::luaRequire);
  lua_setglobal(L, "require");
  lua_getglobal(L, "setmetatable");
  lua_pushcclosure(L, &ScriptSandbox::luaSetMetatable, 1);
  lua_setglobal(L, "setmetatable");
  lua_getglobal(L, LUA_STRLIBNAME);
  lua_pushnil(L);
  lua_setfield(L, -2, "dump");
  for (const char* name : {"match", "gmatch", "gsub"}) {
    lua_pushstring(L, name);
    lua_pushcclosure(L, &ScriptSandbox::luaNoPatterns, 1);
    lua_setfield(L, -2, name);
  }
  lua_getfield(L, -1, "find");
  lua_pushcclosure(L, &ScriptSandbox::luaPlainFind, 1);
  lua_setfield(L, -2, "find");
  lua_pop(L, 1);
  // Lua seeds math.random from the clock and an address; a scene must be the same every run.
  lua_getglobal(L, LUA_MATHLIBNAME);
  lua_getfield(L, -1, "randomseed");
  lua_pushvalue(L, -1);
  lua_setfield(L, LUA_REGISTRYINDEX, kRandomSeedKey);
  lua_pushinteger(L, 1);
  lua_call(L, 1, 0);
  lua_pushcfunction(L, &ScriptSandbox::luaRandomSeed);
  lua_setfield(L, -2, "randomseed");
  lua_pop(L, 1);
  lua_newtable(L);
  lua_setfield(L, LUA_REGISTRYINDEX, kLoadedKey);
  return 0;
}

int ScriptSandbox::luaRandomSeed(lua_State* L) {
  // Only explicit seeds: randomseed() without one would seed from the clock.
  const lua_Integer seed = luaL_checkinteger(L, 1);
  lua_getfield(L, LUA_REGISTRYINDEX, kRandomSeedKey);
  lua_pushinteger(L, seed);
  lua_call(L, 1, 0);
  return 0;
}

int ScriptSandbox::luaSetMetatable(lua_State* L) {
  // Lua runs finalizers with hooks off, so the instruction budget cannot stop a __gc that
  // loops: it would hang whoever triggers the collection (the daemon's conductor). A table is
  // only marked for finalization when its metatable has __gc at this moment, so refusing that
  // here keeps every finalizer out, however the metatable changes later.
  if (lua_type(L, 2) == LUA_TTABLE) {
    lua_pushstring(L, "__gc");
    const bool finalizer = lua_rawget(L, 2) != LUA_TNIL;
    lua_pop(L, 1);
    if (finalizer) {
      return luaL_error(L,
                        "setmetatable: __gc finalizers are not available in scene scripts (they "
                        "run outside the instruction budget)");
    }
  }
  return callWrapped(L);
}

int ScriptSandbox::luaNoPatterns(lua_State* L) {
  return luaL_error(
      L,
      "string.%s: Lua patterns are not available in scene scripts (their matching time cannot be "
      "bounded); use string.find(s, text, 1, true)",
      lua_tostring(L, lua_upvalueindex(1)));
}

int ScriptSandbox::luaPlainFind(lua_State* L) {
  if (!lua_toboolean(L, 4)) {
    return luaL_error(L,
                      "string.find: only plain search is available in scene scripts (patterns "
                      "cannot be bounded); "
                      "pass true as the fourth argument");
  }
  return callWrapped(L);
}

int ScriptSandbox::luaLoad(lua_State* L) {
  size_t length = 0;
  const char* text = lua_tolstring(L, 1, &length);
  if (text == nullptr || lua_type(L, 1) != LUA_TSTRING) {
    return luaL_error(L, "load: only source text can be loaded in a scene script (got a %s)",
                      luaL_typename(L, 1));
  }
  const char* chunkName = luaL_optstring(L, 2, "=(load)");
  const char* mode = luaL_optstring(L, 3, "t");
  if (std::strcmp(mode, "t") != 0)
    return luaL_error(L, "load: mode \"%s\" is not allowed (text chunks only)", mode);
  const bool hasEnv = !lua_isnone(L, 4);
  if (luaL_loadbufferx(L, text, length, chunkName, "t") != LUA_OK) {
    luaL_pushfail(L);
    lua_insert(L, -2);
    return 2;
  }
  if (hasEnv) {
    lua_pushvalue(L, 4);
    if (lua_setupvalue(L, -2, 1) == nullptr) lua_pop(L, 1);
  }
  return 1;
}

int ScriptSandbox::luaPrint(lua_State* L) {
  // Counted before the buffer, which takes a stack slot of its own.
  const int n = lua_gettop(L);
  luaL_Buffer buffer;
  luaL_buffinit(L, &buffer);
  for (int i = 1; i <= n; ++i) {
    if (i > 1) luaL_addchar(&buffer, '\t');
    luaL_tolstring(L, i, nullptr);
    luaL_addvalue(&buffer);
  }
  luaL_pushresult(&buffer);
  if (!of(L).quiet) std::fprintf(stderr, "[script] %s\n", lua_tostring(L, -1));
  return 0;
}

int ScriptSandbox::luaRequire(lua_State* L) {
  ScriptSandbox& self = of(L);
  size_t length = 0;
  const char* name = luaL_checklstring(L, 1, &length);
  if (!validModuleName(name, length)) {
    return luaL_error(
        L, "require \"%s\": module names are dotted words (like \"lib.paper\"), not paths", name);
  }
  lua_getfield(L, LUA_REGISTRYINDEX, kLoadedKey);
  lua_getfield(L, -1, name);
  if (lua_isstring(L, -1) && std::strcmp(lua_tostring(L, -1), kLoadingSentinel) == 0) {
    return luaL_error(L, "require \"%s\": circular require", name);
  }
  if (!lua_isnil(L, -1)) return 1;
  lua_pop(L, 1);

  int status = LUA_OK;
  {
    // C++ objects live only inside this block: nothing below it may unwind past them.
    std::string relative = name;
    for (char& c : relative) {
      if (c == '.') c = '/';
    }
    relative += ".lua";
    std::string path, why;
    for (const std::string& root : {self.libraryRoot_, self.folder_}) {
      if (root.empty()) continue;
      try {
        path = resolvePathBelow(root, relative);
        break;
      } catch (const std::exception& e) {
        if (why.empty()) why = e.what();
      }
    }
    if (path.empty()) {
      lua_pushfstring(L,
                      "module \"%s\" not found: require looks only for %s in the scene library and "
                      "the script's folder "
                      "(no C modules, no paths)",
                      name, relative.c_str());
      status = LUA_ERRFILE;
    } else {
      std::string source;
      try {
        source = readSmallFile(path, self.limits_.maxSourceBytes);
      } catch (const std::exception& e) {
        lua_pushstring(L, e.what());
        status = LUA_ERRFILE;
      }
      if (status == LUA_OK) {
        self.requiredFiles_.push_back(path);
        status = luaL_loadbufferx(L, source.data(), source.size(), ("@" + relative).c_str(), "t");
      }
    }
  }
  if (status != LUA_OK) {
    luaL_where(L, 1);
    lua_insert(L, -2);
    lua_concat(L, 2);
    return lua_error(L);
  }
  lua_pushstring(L, kLoadingSentinel);
  lua_setfield(L, 2, name);
  lua_pushvalue(L, 1);
  lua_call(L, 1, 1);
  if (lua_isnil(L, -1)) {
    lua_pop(L, 1);
    lua_pushboolean(L, 1);
  }
  lua_pushvalue(L, -1);
  lua_setfield(L, 2, name);
  return 1;
}

void ScriptSandbox::startBudget(long instructionBudget, std::size_t allocationBudget) {
  instructions_ = 0;
  allocated_ = 0;
  allocationBudget_ = allocationBudget;
  allocationBudgetHit_ = false;
  budget_ = instructionBudget;
  budgetSpent_ = false;
  memoryCapHit_ = false;
  lastSource_[0] = '\0';
  lastLine_ = 0;
  lua_sethook(L_, &ScriptSandbox::countHook, LUA_MASKCOUNT, kHookInterval);
}

void ScriptSandbox::run(const std::string& source, const std::string& chunkName,
                        long instructionBudget, std::size_t allocationBudget) {
  startBudget(instructionBudget, allocationBudget);
  int status = luaL_loadbufferx(L_, source.data(), source.size(), ("@" + chunkName).c_str(), "t");
  if (status == LUA_OK) status = lua_pcall(L_, 0, 0, 0);
  if (status != LUA_OK) throwError(status, chunkName);
}

// The host reads globals raw: a script may have given _G an __index metamethod, which must
// not run (and could raise) outside a protected call.
static int rawGlobal(lua_State* L, const char* name) {
  lua_rawgeti(L, LUA_REGISTRYINDEX, LUA_RIDX_GLOBALS);
  lua_pushstring(L, name);
  const int type = lua_rawget(L, -2);
  lua_remove(L, -2);
  return type;
}

bool ScriptSandbox::hasGlobalFunction(const char* name) {
  if (!lua_checkstack(L_, 3)) throw std::bad_alloc();
  const bool is = rawGlobal(L_, name) == LUA_TFUNCTION;
  lua_pop(L_, 1);
  return is;
}

void ScriptSandbox::call(const char* name, std::initializer_list<double> args,
                         long instructionBudget, std::size_t allocationBudget) {
  startBudget(instructionBudget, allocationBudget);
  if (!lua_checkstack(L_, static_cast<int>(args.size()) + 3)) throw std::bad_alloc();
  rawGlobal(L_, name);
  for (double a : args) lua_pushnumber(L_, a);
  const int status = lua_pcall(L_, static_cast<int>(args.size()), 0, 0);
  if (status != LUA_OK) throwError(status, name);
}

void ScriptSandbox::throwError(int status, const std::string& chunkName) {
  std::string message = lua_type(L_, -1) == LUA_TSTRING
                            ? lua_tostring(L_, -1)
                            : fmt::format("(error object is a {} value)", luaL_typename(L_, -1));
  lua_pop(L_, 1);
  lua_settop(L_, 0);
  InputLocation location{chunkName, "", 0};
  if (status == LUA_ERRMEM || ((memoryCapHit_ || allocationBudgetHit_) &&
                               message.find("not enough memory") != std::string::npos)) {
    message = allocationBudgetHit_ && !memoryCapHit_
                  ? fmt::format(
                        "allocation budget of {} MiB a call exceeded (a string grown piece by "
                        "piece? build "
                        "a table and use table.concat)",
                        allocationBudget_ >> 20)
                  : fmt::format("memory cap of {} MiB exceeded", limits_.memoryBytes >> 20);
    if (lastSource_[0] != '\0') location = {lastSource_, "", lastLine_};
    throw InputError(location, message);
  }
  // Lua prefixes run-time errors with "chunk:line: "; keep it as the location.
  const std::size_t colon = message.find(':');
  if (colon != std::string::npos && colon > 0 && message.find('\n') > colon) {
    std::size_t end = colon + 1;
    while (end < message.size() && end < colon + 10 && message[end] >= '0' && message[end] <= '9')
      ++end;
    if (end > colon + 1 && message.compare(end, 2, ": ") == 0) {
      location.file = message.substr(0, colon);
      location.line = std::stoi(message.substr(colon + 1, end - colon - 1));
      message = message.substr(end + 2);
    }
  }
  throw InputError(location, message);
}

}  // namespace parallax
