#pragma once
// The Lua 5.4 state a scene script runs in. A script is untrusted content (DESIGN.md), so:
//   - only the base, string, table, math, utf8 and coroutine libraries; no io, os, debug,
//     package, dofile, loadfile, collectgarbage or string.dump;
//   - `load` accepts source text only (mode "t": no binary chunks);
//   - `require` finds modules by dotted name only below the scene library's folder or the
//     script's own folder (no paths, no C modules);
//   - an instruction budget per call (a count hook), sticky once spent so that pcall cannot
//     swallow it, and a memory cap enforced by the allocator;
//   - Lua patterns (string.find/match/gmatch/gsub) are refused: their backtracking can run
//     for hours inside one C call, where no budget can reach; plain string.find is allowed;
//   - setmetatable refuses a __gc field: Lua runs finalizers with hooks off, out of the
//     budget's reach;
//   - math.random is seeded the same way every time, so a script is deterministic.
// Every failure becomes an InputError naming the script (or module) and line; the host and
// the sandbox stay usable afterwards.

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

#include "common/input_error.h"

struct lua_State;
struct lua_Debug;

namespace parallax {

struct ScriptLimits {
  long loadInstructions = 200'000'000;              // running the script once (building the scene)
  long updateInstructions = 20'000'000;             // one update(t, dt) call
  std::size_t memoryBytes = std::size_t{64} << 20;  // everything the Lua state holds at once
  // Bytes allocated per call, freed or not. The instruction budget counts VM instructions, but
  // one instruction can copy megabytes (s = s .. "x" in a loop is quadratic), so the copying
  // work is bounded here.
  std::size_t loadAllocationBytes = std::size_t{4} << 30;
  std::size_t updateAllocationBytes = std::size_t{1} << 30;
  // What the binding itself allocates on the script's behalf (outside the Lua heap).
  long maxTriangles = 4'000'000;
  // Each instance is an Embree geometry of its own, about 4 KB and a BVH build: 400,000 took
  // 1.7 GB and 21 s to build, where 4 million triangles in one mesh take a fraction of that.
  long maxInstances = 100'000;
  long maxTexturePixels = 16L << 20;
  std::uintmax_t maxSourceBytes = 1u << 20;  // a script or module file

  // Throws InputError naming the field.
  void validate() const;
};

class ScriptSandbox {
 public:
  // `folder`: the script's folder; `libraryRoot`: the scene library's folder (for require).
  ScriptSandbox(const ScriptLimits& limits, std::string folder, std::string libraryRoot);
  ~ScriptSandbox();
  ScriptSandbox(const ScriptSandbox&) = delete;
  ScriptSandbox& operator=(const ScriptSandbox&) = delete;

  static ScriptSandbox& of(lua_State* L);
  lua_State* state() { return L_; }
  const ScriptLimits& limits() const { return limits_; }
  const std::string& folder() const { return folder_; }

  // Runs source text as a chunk named `chunkName` (shown in errors, e.g. "cornell.lua").
  void run(const std::string& source, const std::string& chunkName, long instructionBudget,
           std::size_t allocationBudget);
  // Calls the global function `name` with numeric arguments, if it exists.
  bool hasGlobalFunction(const char* name);
  // Starts a call's budgets (run and call do it themselves; the host calls it before its own
  // work in the state, such as publishing parameters).
  void startBudget(long instructionBudget, std::size_t allocationBudget);
  void call(const char* name, std::initializer_list<double> args, long instructionBudget,
            std::size_t allocationBudget);

  // Files `require` read (canonical paths), for the hot-reload watcher.
  const std::vector<std::string>& requiredFiles() const { return requiredFiles_; }
  std::size_t memoryUsed() const { return memoryUsed_; }
  long instructionsUsed() const { return instructions_; }

  // print() writes "[script] ..." lines to stderr unless quiet (the fuzzer sets it).
  bool quiet = false;
  // Whatever the binding keeps per state (see scene_api.h).
  void* context = nullptr;

 private:
  static void* allocate(void* ud, void* ptr, std::size_t osize, std::size_t nsize);
  static void countHook(lua_State* L, lua_Debug* ar);
  static int openSafeLibraries(lua_State* L);
  static int luaRequire(lua_State* L);
  static int luaLoad(lua_State* L);
  static int luaPrint(lua_State* L);
  static int luaRandomSeed(lua_State* L);
  static int luaNoPatterns(lua_State* L);
  static int luaSetMetatable(lua_State* L);
  static int luaPlainFind(lua_State* L);
  void recordWhere();
  // Pops the error at the top of the stack and throws it as an InputError.
  [[noreturn]] void throwError(int status, const std::string& chunkName);

  ScriptLimits limits_;
  std::string folder_;
  std::string libraryRoot_;
  lua_State* L_ = nullptr;
  std::size_t memoryUsed_ = 0;
  bool memoryCapHit_ = false;
  std::size_t allocated_ = 0;  // this call
  std::size_t allocationBudget_ = 0;
  bool allocationBudgetHit_ = false;
  long instructions_ = 0;
  long budget_ = 0;
  bool budgetSpent_ = false;
  char lastSource_[64] = {};  // where the count hook last saw the script (for memory errors)
  int lastLine_ = 0;
  std::vector<std::string> requiredFiles_;
};

}  // namespace parallax
