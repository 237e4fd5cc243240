#include "scripts/scripted_scene.h"

#include <gtest/gtest.h>

#include "script_test_util.h"

namespace parallax {
namespace {

using testing::smallLimits;
using testing::TempFolder;

const char* const kHelperV1 = "return {slices = 8}\n";
const char* const kHelperV2 = "return {slices = 16}\n";

std::string sceneSource(int stacks) {
  return "local helper = require \"helper\"\n"
         "local m = px.diffuse{color = {0.5, 0.5, 0.5}, texture = px.texture{path = "
         "\"wood.png\"}}\n"
         "px.sphere{radius = 1, slices = helper.slices, stacks = " +
         std::to_string(stacks) + ", material = m}\n";
}

TEST(ScriptedScene, ReloadsWhenTheScriptOrWhatItReadChanges) {
  TempFolder folder;
  folder.write("helper.lua", kHelperV1);
  folder.write("wood.png", "not really a png: textures are read at render time");
  const std::string path = folder.write("scene.lua", sceneSource(4));
  ScriptedScene scene(path, smallLimits());
  EXPECT_EQ(scene.scene().triangleCount(), 2 * 8 * 3);
  EXPECT_EQ(scene.watchedFiles().size(), 3u);
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kUnchanged);

  folder.write("scene.lua", sceneSource(5));
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  EXPECT_EQ(scene.scene().triangleCount(), 2 * 8 * 4);

  folder.write("helper.lua", kHelperV2);
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  EXPECT_EQ(scene.scene().triangleCount(), 2 * 16 * 4);

  const std::uint64_t version = scene.version();
  folder.write("wood.png", "another image");
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  EXPECT_GT(scene.version(), version);
  EXPECT_EQ(scene.reloads(), 3);
}

TEST(ScriptedScene, FailedReloadKeepsTheOldSceneAndReportsTheLine) {
  TempFolder folder;
  folder.write("helper.lua", kHelperV1);
  folder.write("wood.png", "x");
  const std::string path = folder.write("scene.lua", sceneSource(4));
  ScriptedScene scene(path, smallLimits());
  const long before = scene.scene().triangleCount();

  folder.write("scene.lua", sceneSource(4) + "px.box{size = {1, 1}, material = m}\n");
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kFailed);
  EXPECT_NE(scene.lastError().find("scene.lua:4: px.box: size"), std::string::npos)
      << scene.lastError();
  EXPECT_EQ(scene.scene().triangleCount(), before);
  EXPECT_EQ(scene.reloadIfChanged(),
            ScriptedScene::Reload::kUnchanged);  // no retry until it changes

  folder.write("helper.lua", "return {slices = }\n");  // a broken module, the script unchanged
  folder.write("scene.lua", sceneSource(6));
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kFailed);
  EXPECT_NE(scene.lastError().find("helper.lua:1:"), std::string::npos) << scene.lastError();

  folder.write("helper.lua", kHelperV1);
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  EXPECT_EQ(scene.scene().triangleCount(), 2 * 8 * 5);
  EXPECT_EQ(scene.lastError(), "");
  EXPECT_EQ(scene.failedReloads(), 2);
}

TEST(ScriptedScene, ParametersSurviveReloadAndRebuildStaticScenes) {
  TempFolder folder;
  const std::string path =
      folder.write("p.lua",
                   "local n = px.param{name = \"slices\", default = 6, min = 3, max = 64, "
                   "description = \"sphere slices\"}\n"
                   "px.sphere{radius = 1, slices = n, stacks = 2, material = px.diffuse{}}\n");
  ScriptedScene scene(path, smallLimits());
  EXPECT_EQ(scene.scene().triangleCount(), 2 * 6);
  EXPECT_TRUE(scene.setParameter("slices", 10));  // static: built again
  EXPECT_EQ(scene.scene().triangleCount(), 2 * 10);
  folder.write("p.lua",
               "local n = px.param{name = \"slices\", default = 6, min = 3, max = 64, description "
               "= \"sphere slices\"}\n"
               "px.sphere{radius = 1, slices = n, stacks = 3, material = px.diffuse{}}\n");
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  EXPECT_EQ(scene.scene().triangleCount(), 2 * 10 * 2);
  EXPECT_THROW(scene.setParameter("slices", 100), InputError);
}

TEST(ScriptedScene, AnimatedSceneKeepsItsTimeAcrossReloadAndSurvivesUpdateErrors) {
  TempFolder folder;
  const std::string path =
      folder.write("a.lua",
                   "local ball = px.sphere{radius = 0.1, material = px.diffuse{}}\n"
                   "function update(t) px.set_transform(ball, px.translate(t, 0, 0)) end\n");
  ScriptedScene scene(path, smallLimits());
  EXPECT_TRUE(scene.setTime(2.0));
  folder.write("a.lua",
               "local ball = px.sphere{radius = 0.1, material = px.diffuse{}}\n"
               "function update(t)\n"
               "  if t > 3 then error(\"too late\") end\n"
               "  px.set_transform(ball, px.translate(2 * t, 0, 0))\n"
               "end\n");
  EXPECT_EQ(scene.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  EXPECT_DOUBLE_EQ(scene.scene().instances[0].worldFromObject.translation().x(), 4.0);
  EXPECT_FALSE(scene.setTime(3.5));
  EXPECT_NE(scene.lastError().find("a.lua:3: too late"), std::string::npos) << scene.lastError();
  EXPECT_DOUBLE_EQ(scene.scene().instances[0].worldFromObject.translation().x(), 4.0);
  EXPECT_TRUE(scene.setTime(2.5));
  EXPECT_DOUBLE_EQ(scene.scene().instances[0].worldFromObject.translation().x(), 5.0);
}

TEST(ScriptedScene, MissingScriptIsAClearError) {
  TempFolder folder;
  try {
    ScriptedScene scene(folder.file("absent.lua"), smallLimits());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("absent.lua"), std::string::npos);
  }
}

}  // namespace
}  // namespace parallax
