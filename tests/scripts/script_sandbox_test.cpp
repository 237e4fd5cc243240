#include "scripts/script_sandbox.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "script_test_util.h"
#include "scripts/scene_api.h"

namespace parallax {
namespace {

using testing::loadError;
using testing::smallLimits;
using testing::TempFolder;

// Every escape attempt is a scene that would be fine but for its last line.
std::string withPrelude(const std::string& attempt) {
  return "local m = px.diffuse{color = {0.5, 0.5, 0.5}}\n"
         "px.box{material = m}\n" +
         attempt + "\n";
}

// After a failure the same process loads and updates a real scene as if nothing happened.
void expectHostUsable(const std::string& folder) {
  const auto script = SceneScript::loadFile(testing::sceneLibrary() + "/orbit.lua", smallLimits());
  EXPECT_GT(script->scene().triangleCount(), 1000);
  EXPECT_NO_THROW(script->setTime(0.5));
  EXPECT_EQ(loadError(withPrelude("local x = 1"), folder), "");
}

struct Escape {
  const char* what;
  const char* code;      // line 3 of the script
  const char* expected;  // in the error message
};

class EscapeAttempt : public ::testing::TestWithParam<Escape> {};

TEST_P(EscapeAttempt, FailsWithAClearErrorAndTheLine) {
  TempFolder folder;
  std::filesystem::create_symlink("/etc/passwd", folder.file("passwd_link"));
  const Escape& e = GetParam();
  const std::string error = loadError(withPrelude(e.code), folder.path());
  ASSERT_NE(error, "") << e.what << " was not stopped";
  EXPECT_NE(error.find(e.expected), std::string::npos) << e.what << ": " << error;
  EXPECT_NE(error.find("attempt.lua:3"), std::string::npos)
      << e.what << " error without its line: " << error;
  expectHostUsable(folder.path());
}

INSTANTIATE_TEST_SUITE_P(
    Sandbox, EscapeAttempt,
    ::testing::Values(
        Escape{"os.execute", R"(os.execute("touch /tmp/parallax_pwned"))", "global 'os'"},
        Escape{"io.open", R"(local f = io.open("/etc/passwd"))", "global 'io'"},
        Escape{"require ffi", R"(local ffi = require "ffi")", "module \"ffi\" not found"},
        Escape{"require a path", R"(require "../../etc/passwd")", "not paths"},
        Escape{"package.loadlib", R"(package.loadlib("libc.so.6", "system"))", "global 'package'"},
        Escape{"binary chunk", R"(assert(load("\27LuaT\0\25\147\r\n\26\n\4\8\8xV\0\0")))",
               "binary chunk"},
        Escape{"load mode b", R"(load("return 1", "x", "b"))", "mode \"b\" is not allowed"},
        Escape{"string.dump", R"(local s = string.dump(function() end))", "field 'dump'"},
        Escape{"string.dump via metatable", R"(local s = ("").dump(print))", "field 'dump'"},
        Escape{"debug.sethook", R"(debug.sethook())", "global 'debug'"},
        Escape{"dofile", R"(dofile("/etc/passwd"))", "global 'dofile'"},
        Escape{"collectgarbage", R"(collectgarbage("stop"))", "global 'collectgarbage'"},
        Escape{"mesh loader ..", R"(px.model{path = "../../etc/passwd"})", "\"..\" is not allowed"},
        Escape{"texture absolute", R"(px.texture{path = "/etc/passwd"})",
               "absolute paths are not allowed"},
        Escape{"symlink out", R"(px.texture{path = "passwd_link"})",
               "leads outside the script's folder"},
        Escape{"endless loop", "while true do end", "instruction budget"},
        // Lua runs finalizers with hooks off: this one would loop for ever at the next
        // collection, out of the budget's reach.
        Escape{"endless finalizer",
               "setmetatable({}, {__gc = function() while true do end end}) local t = {} for i "
               "= 1, 1e5 do t[i] = {} end",
               "__gc finalizers are not available"},
        // A __gc present when the metatable is set marks the table; refusing any value there
        // keeps a function put in later from running.
        Escape{"finalizer put in later",
               "local mt = {__gc = true} setmetatable({}, mt) mt.__gc = function() while true do "
               "end end",
               "__gc finalizers are not available"},
        Escape{"endless loop in pcall", "while true do pcall(function() while true do end end) end",
               "instruction budget"},
        Escape{"memory bomb",
               R"(local t = {} for i = 1, 1e9 do t[i] = string.rep("x", 1e6, tostring(i)) end)",
               "memory cap of 16 MiB exceeded"},
        // Lua's stack of a million slots needs more than 16 MiB: the cap stops it first.
        Escape{"deep recursion", "local function f(n) return 1 + f(n + 1) end f(1)",
               "memory cap of 16 MiB exceeded"},
        Escape{"quadratic string growth", R"(local s = "" for i = 1, 1e8 do s = s .. "xx" end)",
               "allocation budget"},
        Escape{"pattern backtracking",
               R"(string.find(string.rep("a", 3000), string.rep("a-", 12) .. "b"))",
               "only plain search"},
        Escape{"gsub", R"(local s = ("abc"):gsub("b", "x"))", "patterns are not available"},
        Escape{"huge tessellation",
               "px.sphere{radius = 1, slices = 4096, stacks = 4096, material = m}",
               "limit of 4000000"}),
    [](const ::testing::TestParamInfo<Escape>& param) {
      std::string name = param.param.what;
      for (char& c : name) {
        if (!isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return name;
    });

TEST(Sandbox, DeepRecursionWithinTheMemoryCapIsAStackOverflow) {
  TempFolder folder;
  ScriptOptions options = smallLimits();
  options.limits.memoryBytes = std::size_t{256} << 20;
  options.limits.loadInstructions = 100'000'000;
  const std::string error = loadError(
      withPrelude("local function f(n) return 1 + f(n + 1) end f(1)"), folder.path(), options);
  EXPECT_NE(error.find("attempt.lua:3: stack overflow"), std::string::npos) << error;
  expectHostUsable(folder.path());
}

TEST(Sandbox, MetamethodsOnTheGlobalsDoNotReachTheHost) {
  TempFolder folder;
  // The host looks up update() and publishes params after loading: raw accesses, so these
  // metamethods never run outside a protected call.
  const std::string source = withPrelude(
      "setmetatable(_G, {__index = function() error(\"no reading\") end,\n"
      "                  __newindex = function() while true do end end})");
  EXPECT_EQ(loadError(source, folder.path()), "");
  auto script = SceneScript::loadSource(
      withPrelude(
          "function update(t) end\nsetmetatable(_G, {__index = function() error(\"boom\") end})"),
      "g.lua", folder.path(), smallLimits());
  EXPECT_NO_THROW(script->setTime(1.0));
}

// Every object is an Embree instance of its own (about 4 KB and a BVH build each): their count
// has a limit of its own, not the triangles' 4 million.
TEST(Sandbox, ObjectsAreCountedAgainstTheirOwnLimit) {
  TempFolder folder;
  ScriptOptions options = smallLimits();
  options.limits.maxInstances = 5;
  // The prelude's box is the first object: four more fit.
  EXPECT_EQ(loadError(withPrelude("local b = px.box{material = m}\n"
                                  "for i = 1, 3 do px.instance(b, px.translate(i, 0, 0)) end"),
                      folder.path(), options),
            "");
  const std::string instances =
      loadError(withPrelude("local b = px.box{material = m}\n"
                            "for i = 1, 4 do px.instance(b, px.translate(i, 0, 0)) end"),
                folder.path(), options);
  EXPECT_NE(instances.find("attempt.lua:4: px.instance: 6 objects would pass the scene's limit "
                           "of 5"),
            std::string::npos)
      << instances;
  const std::string shapes =
      loadError(withPrelude("for i = 1, 5 do px.sphere{material = m} end"), folder.path(), options);
  EXPECT_NE(shapes.find("attempt.lua:3: px.sphere: 6 objects would pass"), std::string::npos)
      << shapes;
}

TEST(Sandbox, SetmetatableWithoutFinalizerStillWorks) {
  TempFolder folder;
  EXPECT_EQ(
      loadError(withPrelude("local v = setmetatable({}, {__index = function() return 7 end})\n"
                            "assert(v.anything == 7)"),
                folder.path()),
      "");
}

TEST(Sandbox, PrintWritesItsArgumentsOnly) {
  TempFolder folder;
  ScriptOptions options = smallLimits();
  options.quiet = false;
  ::testing::internal::CaptureStderr();
  const std::string error = loadError(withPrelude("print(\"a\", 2)"), folder.path(), options);
  const std::string printed = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(error, "");
  // The string buffer's own stack slot was once printed too ("a\t2\tuserdata: 0x...").
  EXPECT_EQ(printed, "[script] a\t2\n");
}

TEST(Sandbox, PlainFindStillWorks) {
  TempFolder folder;
  EXPECT_EQ(
      loadError(withPrelude("assert(string.find(\"a-b\", \"-\", 1, true) == 2)"), folder.path()),
      "");
}

TEST(Sandbox, ErrorInUpdateKeepsTheLastGoodSceneAndNamesTheLine) {
  TempFolder folder;
  const std::string source = withPrelude(
      "local ball = px.sphere{radius = 0.2, material = m}\n"
      "function update(t, dt)\n"
      "  px.set_transform(ball, px.translate(t, 0, 0))\n"
      "  if t >= 1 then error(\"the ball fell off\") end\n"
      "end");
  auto script = SceneScript::loadSource(source, "anim.lua", folder.path(), smallLimits());
  ASSERT_TRUE(script->animated());
  script->setTime(0.5);
  const Eigen::Vector3d before = script->scene().instances[1].worldFromObject.translation();
  EXPECT_DOUBLE_EQ(before.x(), 0.5);
  try {
    script->setTime(1.0);
    FAIL() << "update's error was swallowed";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().file, "anim.lua");
    EXPECT_EQ(e.location().line, 6);
    EXPECT_NE(std::string(e.what()).find("the ball fell off"), std::string::npos);
  }
  // The half-done update (the ball already moved to x = 1) was undone.
  EXPECT_DOUBLE_EQ(script->scene().instances[1].worldFromObject.translation().x(), 0.5);
  script->setTime(0.75);
  EXPECT_DOUBLE_EQ(script->scene().instances[1].worldFromObject.translation().x(), 0.75);
}

TEST(Sandbox, EndlessLoopInUpdateStopsAndTheScriptStaysUsable) {
  TempFolder folder;
  const std::string source =
      withPrelude("function update(t, dt) if t > 1 then while true do end end end");
  auto script = SceneScript::loadSource(source, "loop.lua", folder.path(), smallLimits());
  try {
    script->setTime(2.0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("loop.lua:3: instruction budget"), std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(script->setTime(0.5));  // a fresh budget for the next call
}

TEST(Sandbox, SyntaxAndApiErrorsNameTheScriptAndLine) {
  TempFolder folder;
  EXPECT_NE(loadError("local a = 1\nlocal b = = 2\n", folder.path()).find("attempt.lua:2:"),
            std::string::npos);
  const std::string misspelt =
      loadError(withPrelude("px.box{sise = {1, 1, 1}, material = m}"), folder.path());
  EXPECT_NE(misspelt.find("attempt.lua:3: px.box: options: unknown field \"sise\""),
            std::string::npos)
      << misspelt;
  const std::string wrongHandle = loadError(
      withPrelude("local l = px.point{position = {0, 1, 0}}\npx.box{material = l}"), folder.path());
  EXPECT_NE(wrongHandle.find("attempt.lua:4: px.box: material: expected a material, got light"),
            std::string::npos)
      << wrongHandle;
  const std::string noSize =
      loadError(withPrelude("local t = px.image{pixels = {}}"), folder.path());
  EXPECT_NE(noSize.find("attempt.lua:3: px.image: width and height: required"), std::string::npos)
      << noSize;
  const std::string nan = loadError(withPrelude("px.translate(0/0, 0, 0)"), folder.path());
  EXPECT_NE(nan.find("x: must be finite"), std::string::npos) << nan;
  const std::string inUpdate = withPrelude("function update(t) px.box{material = m} end");
  EXPECT_NE(loadError(inUpdate, folder.path()).find("not in update()"), std::string::npos);
  EXPECT_NE(loadError("local x = 1\n", folder.path()).find("nothing to draw"), std::string::npos)
      << loadError("local x = 1\n", folder.path());
}

TEST(Sandbox, RandomNumbersAreTheSameEveryRun) {
  TempFolder folder;
  const std::string source = withPrelude(
      "for i = 1, 5 do px.sphere{radius = 0.1, material = m,\n"
      "  transform = px.translate(math.random(), math.random(), math.random())} end");
  auto a = SceneScript::loadSource(source, "r.lua", folder.path(), smallLimits());
  auto b = SceneScript::loadSource(source, "r.lua", folder.path(), smallLimits());
  for (size_t i = 0; i < a->scene().instances.size(); ++i) {
    EXPECT_EQ(a->scene().instances[i].worldFromObject.matrix(),
              b->scene().instances[i].worldFromObject.matrix());
  }
  EXPECT_NE(loadError(withPrelude("math.randomseed()"), folder.path()), "");
}

TEST(Sandbox, ParametersTakeDefaultsSettingsAndRanges) {
  TempFolder folder;
  const std::string source = withPrelude(
      "local r = px.param{name = \"radius\", default = 0.5, min = 0.1, max = 2, description = "
      "\"ball radius\"}\n"
      "px.sphere{radius = r, material = m}\n"
      "function update(t) px.set_transform(1, px.identity()) end");
  ScriptOptions options = smallLimits();
  options.parameters["radius"] = 1.5;
  auto script =
      SceneScript::loadSource(withPrelude("local r = px.param{name = \"radius\", default = 0.5, "
                                          "min = 0.1, max = 2, description = \"ball radius\"}\n"
                                          "local ball = px.sphere{radius = r, material = m}\n"
                                          "seen = 0\n"
                                          "function update(t) seen = params.radius; "
                                          "px.set_transform(ball, px.scale(params.radius)) end"),
                              "p.lua", folder.path(), options);
  ASSERT_EQ(script->parameters().size(), 1u);
  EXPECT_EQ(script->parameters()[0].value, 1.5);
  EXPECT_EQ(script->parameters()[0].description, "ball radius");
  script->setParameter("radius", 2.0);
  script->setTime(1.0);
  EXPECT_DOUBLE_EQ(script->scene().instances[1].worldFromObject.linear()(0, 0), 2.0);
  EXPECT_THROW(script->setParameter("radius", 3.0), InputError);
  EXPECT_THROW(script->setParameter("colour", 1.0), InputError);
  options.parameters["radius"] = 5.0;
  EXPECT_NE(loadError(source, folder.path(), options).find("outside its range"), std::string::npos);
  options.parameters = {{"speed", 1.0}};
  EXPECT_NE(loadError(source, folder.path(), options).find("declares no such parameter"),
            std::string::npos);
}

TEST(SceneApi, ReferenceIsCompleteAndCheckedIn) {
  for (const SceneApiEntry& e : sceneApiReference()) {
    EXPECT_GT(std::string(e.description).size(), 10u) << e.name;
    EXPECT_NE(std::string(e.example).find(std::string("px.") + e.name), std::string::npos)
        << e.name;
  }
  // scripts/API.md is what `parallax scene-api` prints; regenerate it when the API changes.
  std::ifstream in(std::string(PARALLAX_SOURCE_DIR) + "/scripts/API.md");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), sceneApiMarkdown())
      << "scripts/API.md is stale: parallax scene-api > scripts/API.md";
}

}  // namespace
}  // namespace parallax
