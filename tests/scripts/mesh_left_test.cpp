// A mirror's or glass's reflection or refraction ray that leaves a bare face of its mesh is
// traced against the scene without that mesh (PhysicalScene::withoutMesh,
// RenderOptions::skipMeshLeft). The mesh lies wholly behind the face the ray moves away from, so
// it could not have met it: the frames must be the ones the whole scene gives, bit for bit, with
// the same rays traced. Frame after frame of orbit.lua, and of mirrors and glass that are flat,
// not convex, hold other objects inside them or are pierced by them.

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "calibration/display/ray_textures.h"
#include "render_both_ways.h"
#include "script_test_util.h"
#include "scripts/scripted_scene.h"
#include "small_display.h"
#include "tracer/frame.h"
#include "tracer/physical_scene.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

using testing::TempFolder;

const testing::SmallDisplay& smallDisplay() {
  static const testing::SmallDisplay display = testing::makeSmallDisplay(150);
  return display;
}

struct Tally {
  long withoutMesh = 0;  // rays traced without the mesh they leave
  long secondary = 0;    // reflection and refraction rays
  int scenesWithout = 0;
};

// Every frame of the script rendered both ways; the pixels compared as floats.
Tally playBothWays(const std::string& path, int frames, double dt) {
  RenderOptions skipping, whole;
  whole.skipMeshLeft = false;
  Tally tally;
  testing::renderBothWays(
      path, frames, dt, smallDisplay(), skipping, whole,
      [&](const PhysicalScene& scene) {
        for (unsigned m = 0; m < scene.meshes().size(); ++m)
          tally.scenesWithout += !!scene.withoutMesh(m);
      },
      [&](const RenderCounters& a, const RenderCounters& b) {
        EXPECT_EQ(b.withoutMeshLeft, 0);
        EXPECT_EQ(a.reflection, b.reflection) << path;
        EXPECT_EQ(a.refraction, b.refraction) << path;
        EXPECT_EQ(a.shadow, b.shadow) << path;
        tally.withoutMesh += a.withoutMeshLeft;
        tally.secondary += a.reflection + a.refraction;
      });
  return tally;
}

TEST(MeshLeft, OrbitFramesEqualTracingTheWholeScene) {
  const Tally t = playBothWays(testing::sceneLibrary() + "/orbit.lua", 8, 0.37);
  EXPECT_EQ(t.scenesWithout, 2 * 8);  // the mirror ball and the glass ball
  // Off the mirror ball every ray leaves it; in the glass ball, half go in.
  EXPECT_GT(t.withoutMesh, t.secondary / 2);
  EXPECT_LT(t.withoutMesh, t.secondary);
}

// A flat mirror (bare on both sides) with a ball in front of it; a mirror torus, whose inner
// half sees itself; a glass ball with a diffuse ball inside it and a glass box a pillar passes
// through (rays that leave the glass there still meet what is inside or across it); a glass
// slab; a light that grazes the mirror.
const char* const kMirrorsAndGlass = R"(
local white = px.diffuse{color = {0.7, 0.7, 0.7}}
local red = px.phong{color = {0.8, 0.2, 0.2}, specular = {0.5, 0.5, 0.5}, shininess = 20}
local chrome = px.mirror{reflectance = {0.9, 0.9, 0.9}}
local glass = px.glass{ior = 1.5, absorption = {0.5, 0.2, 0.1}}
px.grid{width = 2, height = 2, nx = 4, ny = 4, material = white,
        transform = px.rotate_x(-math.pi / 2)}
local mirror = px.plane{width = 1.2, height = 0.9, material = chrome,
                        transform = px.translate(0, 0.5, -0.8) * px.rotate_y(0.3)}
local torus = px.torus{major = 0.25, minor = 0.08, material = chrome}
px.sphere{radius = 0.2, material = glass, transform = px.translate(0.5, 0.35, 0.2)}
px.sphere{radius = 0.08, material = red, transform = px.translate(0.5, 0.35, 0.2)}
px.box{size = {0.3, 0.3, 0.3}, material = glass, transform = px.translate(-0.5, 0.2, 0.3)}
px.cylinder{radius = 0.05, height = 0.9, material = red, transform = px.translate(-0.5, 0.45, 0.3)}
px.box{size = {0.6, 0.02, 0.3}, material = glass, transform = px.translate(0, 0.9, 0.2) * px.rotate_z(0.2)}
px.directional{direction = {0.3, -1, -0.5}, color = {0.5, 0.5, 0.5}}
px.directional{direction = {-1, -1e-3, -0.2}, color = {0.3, 0.3, 0.3}}
px.point{position = {0, 1.2, 0.5}, color = {0.4, 0.4, 0.4}}
px.world_box{min = {-1, -0.1, -1}, max = {1, 1.5, 1}}
function update(t, dt)
  px.set_transform(torus, px.translate(0, 0.45, 0.1) * px.rotate_y(0.7 * t) * px.rotate_x(1.2 + 0.3 * t))
  px.set_transform(mirror, px.translate(0, 0.5, -0.8) * px.rotate_y(0.3 - 0.2 * t))
end
)";

TEST(MeshLeft, MirrorsAndGlassOfEveryShapeEqualTracingTheWholeScene) {
  TempFolder folder;
  const Tally t = playBothWays(folder.write("mirrors.lua", kMirrorsAndGlass), 5, 0.5);
  EXPECT_EQ(t.scenesWithout, 4 * 5);  // the mirror, the torus, the ball and the box of glass
  EXPECT_GT(t.withoutMesh, 1000);
}

// A scene of one mirror: its rays have nothing else to meet, so no scene is built without it;
// and a mirror in a scene too large to build again without it.
TEST(MeshLeft, NoSceneWithoutAMeshWhereItWouldBeEmptyOrCostTooMuch) {
  TempFolder folder;
  const auto physical = [&](const std::string& name, const std::string& source) {
    ScriptedScene script(folder.write(name, source), testing::libraryOptions());
    return std::make_unique<PhysicalScene>(script.scene(), smallDisplay().model.displayableBox);
  };
  const auto alone = physical("alone.lua", R"(
px.sphere{radius = 0.3, material = px.mirror{reflectance = {0.9, 0.9, 0.9}}}
px.directional{direction = {0, -1, -1}, color = {1, 1, 1}}
)");
  EXPECT_FALSE(alone->hasWithoutMeshScenes());
  // 2 · 400 · 199 triangles in the diffuse ball, twice the budget for one scene without the
  // mirror.
  const auto dense = physical("dense.lua", R"(
px.sphere{radius = 0.3, material = px.mirror{reflectance = {0.9, 0.9, 0.9}}}
px.sphere{radius = 0.2, slices = 400, stacks = 200, material = px.diffuse{color = {1, 1, 1}},
          transform = px.translate(0.6, 0, 0)}
px.directional{direction = {0, -1, -1}, color = {1, 1, 1}}
px.world_box{min = {-1, -1, -1}, max = {1, 1, 1}}
)");
  EXPECT_GT(dense->counters().trianglesBuilt, PhysicalScene::kMaxWithoutMeshTriangles);
  EXPECT_FALSE(dense->hasWithoutMeshScenes());
  const auto two = physical("two.lua", R"(
px.sphere{radius = 0.3, material = px.mirror{reflectance = {0.9, 0.9, 0.9}}}
px.sphere{radius = 0.2, material = px.diffuse{color = {1, 1, 1}}, transform = px.translate(0.6, 0, 0)}
px.directional{direction = {0, -1, -1}, color = {1, 1, 1}}
px.world_box{min = {-1, -1, -1}, max = {1, 1, 1}}
)");
  ASSERT_TRUE(two->hasWithoutMeshScenes());
  EXPECT_NE(two->withoutMesh(0), nullptr);
  EXPECT_EQ(two->withoutMesh(1), nullptr);  // diffuse: no reflection rays leave it
}

}  // namespace
}  // namespace parallax
