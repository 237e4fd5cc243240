// Scene scripts: what loading the library scenes, one update of the animated demo, and the
// sandboxed VM cost. Prints figures (Google Benchmark); never passes or fails on time.
//   build/bench/scripts_bench [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <string>

#include "scripts/scene_script.h"

namespace parallax {
namespace {

std::string libraryScene(const std::string& name) {
  return ScriptOptions::defaultSceneLibrary() + "/" + name + ".lua";
}

void loadScene(benchmark::State& state, const std::string& name) {
  ScriptOptions options;
  options.quiet = true;
  long triangles = 0;
  for (auto _ : state) {
    auto script = SceneScript::loadFile(libraryScene(name), options);
    triangles = script->scene().triangleCount();
    // Counted by the hook in steps of 1000: a small script shows 0.
    state.counters["instructions"] = static_cast<double>(script->instructionsUsed());
    state.counters["lua_heap_KiB"] = static_cast<double>(script->memoryUsed()) / 1024.0;
  }
  state.counters["triangles"] = static_cast<double>(triangles);
}
BENCHMARK_CAPTURE(loadScene, cornell, std::string("cornell"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(loadScene, shapes, std::string("shapes"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(loadScene, orbit, std::string("orbit"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(loadScene, statue, std::string("statue"))->Unit(benchmark::kMillisecond);

// One frame of animation: update(t, dt) in Lua, the undo snapshot and Scene::validate().
void updateOrbit(benchmark::State& state) {
  ScriptOptions options;
  auto script = SceneScript::loadFile(libraryScene("orbit"), options);
  double t = 0.0;
  for (auto _ : state) {
    t += 1.0 / 60.0;
    script->setTime(t);
  }
  state.counters["triangles"] = static_cast<double>(script->scene().triangleCount());
}
BENCHMARK(updateOrbit)->Unit(benchmark::kMicrosecond);

// The VM under the count hook: a plain arithmetic loop, reported as VM instructions a second
// (the hook fires every 1000 instructions).
void sandboxedLoop(benchmark::State& state) {
  ScriptOptions options;
  options.quiet = true;
  const std::string source =
      "local m = px.diffuse{}\npx.box{material = m}\nlocal s = 0\nfor i = 1, 5000000 do s = s + i "
      "% 7 end\n";
  long instructions = 0;
  for (auto _ : state) {
    auto script = SceneScript::loadSource(source, "loop.lua", ".", options);
    instructions += script->instructionsUsed();
  }
  state.counters["VM_instructions_per_s"] =
      benchmark::Counter(static_cast<double>(instructions), benchmark::Counter::kIsRate);
}
BENCHMARK(sandboxedLoop)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace parallax

BENCHMARK_MAIN();
