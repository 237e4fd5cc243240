// Animated model files played from scripts (px.animations, px.set_animation): the library's
// walker.lua renders frames that change over time and repeat for the same time, the animated
// parts count as moving for the frame cache, an unset world box covers the whole animation,
// a failing update puts the skinned mesh back, and bad calls are refused with the reason.

#include <gtest/gtest.h>

#include <filesystem>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
#include "script_test_util.h"
#include "tests/assimp_test_models.h"
#include "tracer/physical_scene.h"
#include "tracer/scene_source.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

#define REQUIRE_MODELS() REQUIRE_ASSIMP_TEST_MODEL("X/Testwuson.X")

Frame render(const Scene& scene) {
  static const DisplayModel model = resolveDisplay("demo");
  static const RayTextures textures = generateRayTextures(model, 8);
  const PhysicalScene physical(scene, model.displayableBox);
  return renderFrame(physical, textures, RenderOptions{});
}

ScriptOptions options() {
  ScriptOptions o = testing::smallLimits();
  o.limits.loadInstructions = 20'000'000;
  o.limits.memoryBytes = std::size_t{64} << 20;
  return o;
}

TEST(AnimatedModel, WalkerPlaysItsWalkCycle) {
  REQUIRE_MODELS();
  auto script = SceneScript::loadFile(testing::sceneLibrary() + "/walker.lua", options());
  ASSERT_TRUE(script->animated());
  script->setTime(0.4);
  const Frame a = render(script->scene());
  script->setTime(1.1);
  const Frame b = render(script->scene());
  script->setTime(0.4);
  const Frame again = render(script->scene());
  long changed = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i)
    changed += (a.pixels[i] - b.pixels[i]).cwiseAbs().maxCoeff() > 0.02f ? 1 : 0;
  EXPECT_GT(changed, 100) << "the walk does not show";
  EXPECT_EQ(a.pixels, again.pixels) << "the same time gave another frame";
  // Wuson's one skinned mesh moves (for the frame cache); the pedestal, the floor and the
  // spider's seven meshes do not.
  const Scene& scene = script->scene();
  ASSERT_EQ(scene.movedInstances.size(), 1u);
  EXPECT_GT(scene.meshes[static_cast<size_t>(scene.instances[*scene.movedInstances.begin()].mesh)]
                .positions.size(),
            3000u);
}

TEST(AnimatedModel, AnUnsetWorldBoxCoversTheWholeAnimation) {
  REQUIRE_MODELS();
  const std::string source = R"(
    local white = px.diffuse{}
    local _, box = px.model{path = "assimp:Collada/box_nested_animation.dae", height = 1}
    px.directional{direction = {0, -1, -1}}
    local clips = px.animations(box)
    assert(#clips == 1 and clips[1].duration > 1)
    function update(t) px.set_animation(box, 1, t) end
  )";
  const testing::TempFolder folder;
  auto script = SceneScript::loadSource(source, "box.lua", folder.path(), options());
  std::vector<Box3> boxes;
  for (double t : {0.0, 0.4, 0.9, 1.3}) {
    script->setTime(t);
    boxes.push_back(script->scene().effectiveWorldBox());
  }
  for (const Box3& box : boxes) {
    EXPECT_EQ(box.min, boxes[0].min);
    EXPECT_EQ(box.max, boxes[0].max);
  }
  EXPECT_FALSE(script->scene().movedInstances.empty());
}

TEST(AnimatedModel, BadCallsAreRefusedWithTheReason) {
  REQUIRE_MODELS();
  const testing::TempFolder temp;
  const std::string folder = temp.path();
  auto error = [&](const std::string& call) {
    return testing::loadError(
        "local white = px.diffuse{}\n"
        "local _, wuson = px.model{path = \"assimp:X/Testwuson.X\", height = 1}\n"
        "local _, spider = px.model{path = \"assimp:OBJ/spider.obj\", height = 1}\n" +
            call,
        folder, options());
  };
  EXPECT_EQ(error("px.set_animation(wuson, \"Wuson_Run\", 0.5)"), "");
  EXPECT_NE(
      error("px.set_animation(wuson, \"Dance\", 0)")
          .find(
              "has no animation \"Dance\" (it has: \"Wuson_Run\", \"Wuson_Walk\", \"Wuson_Bind\")"),
      std::string::npos);
  EXPECT_NE(error("px.set_animation(spider, 1, 0)").find("spider.obj\" has no animations"),
            std::string::npos);
  EXPECT_NE(error("px.set_animation(wuson, 4, 0)").find("animation"), std::string::npos);
  EXPECT_NE(error("px.set_animation(wuson, 1, 0/0)").find("time"), std::string::npos);
  EXPECT_NE(error("px.set_animation(white, 1, 0)").find("model"), std::string::npos);
  EXPECT_EQ(error("assert(#px.animations(spider) == 0 and #px.animations(wuson) == 3)"), "");
}

TEST(AnimatedModel, AFailingUpdatePutsTheSkinBack) {
  REQUIRE_MODELS();
  const std::string source = R"(
    local _, wuson = px.model{path = "assimp:X/Testwuson.X", height = 1}
    px.directional{direction = {0, -1, -1}}
    function update(t)
      px.set_animation(wuson, "Wuson_Walk", t, px.translate(t, 0, 0))
      if t > 1 then error("late") end
    end
  )";
  const testing::TempFolder folder;
  auto script = SceneScript::loadSource(source, "fail.lua", folder.path(), options());
  script->setTime(0.5);
  const Scene before = script->scene();
  EXPECT_THROW(script->setTime(1.5), InputError);
  const Scene& after = script->scene();
  for (size_t m = 0; m < before.meshes.size(); ++m)
    EXPECT_EQ(before.meshes[m].positions, after.meshes[m].positions) << m;
  for (size_t i = 0; i < before.instances.size(); ++i)
    EXPECT_EQ(before.instances[i].worldFromObject.matrix(),
              after.instances[i].worldFromObject.matrix());
  EXPECT_EQ(before.motionBounds[0].min, after.motionBounds[0].min);
  // And the model's placement went back too: the next good frame is where it should be.
  script->setTime(0.5);
  for (size_t m = 0; m < before.meshes.size(); ++m)
    EXPECT_EQ(before.meshes[m].positions, script->scene().meshes[m].positions) << m;
}

}  // namespace
}  // namespace parallax
