// A first generation's shadow rays that pass every mesh's bound (PhysicalScene::occluders: a
// sphere, and a flat mesh's plane) add their light without a trip through Embree, and those
// toward a directional light through a closed convex mesh's core add none
// (RenderOptions::boundShadowRays). Nothing could have blocked the first, and the mesh blocks
// the second, so the frames must be the ones that tracing every ray gives, bit for bit: frame after
// frame of animated scripts with directional and point lights, glass, a light that grazes the floor
// and one close above a wall.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
#include "render_both_ways.h"
#include "script_test_util.h"
#include "scripts/scripted_scene.h"
#include "small_display.h"
#include "tracer/frame.h"
#include "tracer/mesh_shapes.h"
#include "tracer/physical_scene.h"
#include "tracer/scene_fixtures.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

using testing::TempFolder;

using Display = testing::SmallDisplay;

const Display& smallDisplay() {
  // 150 px wide: rows end in a partial vector on every target
  static const Display display = testing::makeSmallDisplay(150);
  return display;
}

struct Tally {
  long passed = 0;   // shadow rays not traced: nothing blocks them
  long blocked = 0;  // shadow rays not traced: a core blocks them
  long traced = 0;   // shadow rays traced with the bounds, and without them
  long tracedAll = 0;
};

// Every frame of the script rendered both ways; the pixels compared as floats.
Tally playBothWays(const std::string& path, int frames, double dt) {
  RenderOptions bounded, everyRay;
  everyRay.boundShadowRays = false;
  Tally tally;
  testing::renderBothWays(
      path, frames, dt, smallDisplay(), bounded, everyRay,
      [&](const PhysicalScene& scene) { EXPECT_FALSE(scene.occluders().empty()) << path; },
      [&](const RenderCounters& withBounds, const RenderCounters& without) {
        EXPECT_EQ(without.shadowPassedBounds, 0);
        EXPECT_EQ(without.shadowBlockedByCores, 0);
        tally.passed += withBounds.shadowPassedBounds;
        tally.blocked += withBounds.shadowBlockedByCores;
        tally.traced += withBounds.shadow;
        tally.tracedAll += without.shadow;
      });
  // Every ray left out is one the full trace made, and found unblocked or blocked.
  EXPECT_EQ(tally.traced + tally.passed + tally.blocked, tally.tracedAll) << path;
  return tally;
}

TEST(ShadowRayBounds, OrbitFramesEqualTracingEveryRay) {
  const Tally t = playBothWays(testing::sceneLibrary() + "/orbit.lua", 8, 0.37);
  // Most of the floor's shadow rays pass the wall's plane and the moving objects' spheres; the
  // mirror ball and the beacon block some through their cores.
  EXPECT_GT(t.passed, t.traced);
  EXPECT_GT(t.blocked, 1000);
}

// Glass (its shadow rays carry a transmittance), a point light, a phong pillar, a floor that
// moves; and a light that grazes the floor: its rays stay within the plane's margin of it.
const char* const kMixed = R"(
local white = px.diffuse{color = {0.7, 0.7, 0.7}}
local red = px.phong{color = {0.8, 0.2, 0.2}, specular = {0.5, 0.5, 0.5}, shininess = 20}
local glass = px.glass{ior = 1.5, absorption = {0.5, 0.2, 0.1}}
local floor = px.grid{width = 2, height = 2, nx = 4, ny = 4, material = white,
                      transform = px.rotate_x(-math.pi / 2)}
px.plane{width = 2, height = 1.5, material = white, transform = px.translate(0, 0.75, -1)}
px.box{size = {0.3, 0.3, 0.3}, material = glass, transform = px.translate(0.5, 0.3, 0.2)}
local pillar = px.cylinder{radius = 0.1, height = 0.8, material = red,
                           transform = px.translate(-0.5, 0.4, 0)}
local ball = px.sphere{radius = 0.15, material = red, transform = px.translate(0, 0.5, 0.3)}
px.directional{direction = {0.3, -1, -0.5}, color = {0.5, 0.5, 0.5}}
px.directional{direction = {-1, -1e-4, -0.2}, color = {0.3, 0.3, 0.3}}
local bulb = px.point{position = {0, 1.2, 0.5}, color = {0.4, 0.4, 0.4}}
px.point{position = {0.2, 0.6, -0.999}, color = {0.2, 0.2, 0.2}}
px.world_box{min = {-1, -0.1, -1}, max = {1, 1.5, 1}}
function update(t, dt)
  px.set_transform(ball, px.translate(0.4 * math.cos(t), 0.5, 0.3 * math.sin(t)))
  px.set_transform(floor, px.translate(0, 0.05 * math.sin(t), 0) * px.rotate_x(-math.pi / 2 + 0.1 * t))
  px.set_light(bulb, {position = {0.3 * math.sin(t), 1.2, 0.5}})
end
)";

TEST(ShadowRayBounds, GlassPointLightsAndGrazingLightEqualTracingEveryRay) {
  TempFolder folder;
  const Tally t = playBothWays(folder.write("mixed.lua", kMixed), 6, 0.5);
  EXPECT_GT(t.passed, 1000);
  EXPECT_GT(t.traced, 1000);
}

// The paper's shapes (glass, Phong highlights, a floor) with two point lights, one just above
// the floor, on a flat and a curved screen.
TEST(ShadowRayBounds, ShapesWithPointLightsEqualTracingEveryRay) {
  Scene scene = makeShapesScene();
  scene.addLight(Light::makePoint({0.2, 1.5, 1.0}, {0.8f, 0.8f, 0.7f}));
  scene.addLight(Light::makePoint({-0.6, 0.02, 0.4}, {0.5f, 0.4f, 0.4f}));
  for (double curvature : {0.0, 0.8}) {
    NominalDisplayOptions options;
    options.preset = "demo";
    options.modules = 3;
    options.width = 150;
    options.height = 100;
    options.curvature = curvature;
    const DisplayModel display = makeNominalDisplay(options);
    const PhysicalScene physical(scene, display.displayableBox);
    ASSERT_FALSE(physical.occluders().empty());
    const RayTextures textures = generateRayTextures(display, 1);
    RenderOptions everyRay;
    everyRay.boundShadowRays = false;
    RenderCounters withBounds, without;
    const Frame a = renderFrame(physical, textures, RenderOptions{}, &withBounds);
    const Frame b = renderFrame(physical, textures, everyRay, &without);
    long differing = 0;
    for (size_t p = 0; p < a.pixels.size(); ++p) differing += a.pixels[p] == b.pixels[p] ? 0 : 1;
    EXPECT_EQ(differing, 0) << "curvature " << curvature;
    EXPECT_GT(withBounds.shadowPassedBounds, 1000) << "curvature " << curvature;
    EXPECT_EQ(withBounds.shadow + withBounds.shadowPassedBounds + withBounds.shadowBlockedByCores,
              without.shadow);
  }
}

// A torus lit across its ring, so that its inner half shadows itself, on a floor beside a ball
// and a box: the torus's outer half, the ball, the box and the floor have bare faces (their
// shadow rays are not tested against their own mesh), the torus's inner half has none.
const char* const kSelfShadowing = R"(
local white = px.diffuse{color = {0.7, 0.7, 0.7}}
local gold = px.phong{color = {0.8, 0.6, 0.2}, specular = {0.6, 0.6, 0.5}, shininess = 60}
px.grid{width = 2, height = 2, nx = 4, ny = 4, material = white,
        transform = px.rotate_x(-math.pi / 2)}
local torus = px.torus{major = 0.4, minor = 0.12, material = gold}
px.sphere{radius = 0.15, material = white, transform = px.translate(0.7, 0.3, 0.3)}
px.box{size = {0.2, 0.3, 0.2}, material = gold, transform = px.translate(-0.7, 0.15, 0.2)}
px.directional{direction = {1, -0.15, -0.2}, color = {0.5, 0.5, 0.5}}
px.directional{direction = {0.2, -0.5, -1}, color = {0.3, 0.3, 0.3}}
px.point{position = {-0.1, 0.5, 0.4}, color = {0.2, 0.2, 0.2}}
px.world_box{min = {-1, -0.1, -1}, max = {1, 1.2, 1}}
function update(t, dt)
  px.set_transform(torus, px.translate(0, 0.5, 0) * px.rotate_y(0.7 * t) * px.rotate_x(1.2 + 0.2 * t))
end
)";

TEST(ShadowRayBounds, TorusShadowingItselfEqualsTracingEveryRay) {
  TempFolder folder;
  const Tally t = playBothWays(folder.write("torus.lua", kSelfShadowing), 6, 0.4);
  EXPECT_GT(t.passed, 1000);
  EXPECT_GT(t.traced, 1000);
}

// A flat torus over a floor under a high sun: the floor's rays through its hole or past its rim
// miss its ring and are not traced, those through its tube are blocked by its cores; only those
// close to the tube's surface go to Embree, and the frames are still those of tracing every ray.
const char* const kRingOverFloor = R"(
local white = px.diffuse{color = {0.7, 0.7, 0.7}}
local gold = px.phong{color = {0.8, 0.6, 0.2}, specular = {0.6, 0.6, 0.5}, shininess = 60}
px.grid{width = 2, height = 2, nx = 4, ny = 4, material = white,
        transform = px.rotate_x(-math.pi / 2)}
local torus = px.torus{major = 0.45, minor = 0.12, material = gold}
px.directional{direction = {0.05, -1, 0.02}, color = {0.5, 0.5, 0.5}}
px.directional{direction = {0.4, -1, -0.3}, color = {0.3, 0.3, 0.3}}
px.world_box{min = {-1, -0.1, -1}, max = {1, 1.2, 1}}
function update(t, dt)
  px.set_transform(torus, px.translate(0.1 * t, 0.5, 0) * px.rotate_x(0.1 * t))
end
)";

TEST(ShadowRayBounds, RaysThroughATorussHoleAreNotTraced) {
  TempFolder folder;
  const Tally t = playBothWays(folder.write("ring.lua", kRingOverFloor), 4, 0.5);
  EXPECT_GT(t.blocked, 100);
  EXPECT_GT(t.passed, t.tracedAll / 2);
  // Without the ring 556 of the 3607 are traced (every ray through the torus's sphere that no
  // core blocks); with it 387.
  EXPECT_LT(t.traced, t.tracedAll / 8);
}

// A face is bare only if every corner of its mesh lies behind it (checked here in double, with
// a tolerance of a few float ulps of the scene's size); a flat mesh's faces are bare on both
// sides, a convex mesh's on the outside, and a torus's outside only on part of it.
TEST(ShadowRayBounds, BareFacesHaveTheirWholeMeshBehind) {
  TempFolder folder;
  ScriptOptions options;
  options.quiet = true;
  ScriptedScene script(folder.write("torus.lua", kSelfShadowing), options);
  ASSERT_TRUE(script.setTime(0.3)) << script.lastError();
  const PhysicalScene scene(script.scene(), smallDisplay().model.displayableBox);
  ASSERT_EQ(scene.meshes().size(), 4u);
  std::vector<size_t> front(4, 0), back(4, 0);
  for (size_t m = 0; m < scene.meshes().size(); ++m) {
    const PhysicalMesh& mesh = scene.meshes()[m];
    ASSERT_EQ(mesh.bareFaces.size(), mesh.triangles.size()) << "mesh " << m;
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      const int bare = mesh.bareFaces[t];
      front[m] += (bare & PhysicalMesh::kFrontBare) ? 1 : 0;
      back[m] += (bare & PhysicalMesh::kBackBare) ? 1 : 0;
      const Eigen::Vector3d p0 = mesh.positions[mesh.triangles[t][0]].cast<double>();
      const Eigen::Vector3d n = mesh.faceNormals[t].cast<double>();
      for (const auto& corners : mesh.triangles) {
        for (std::uint32_t c : corners) {
          const double height = n.dot(mesh.positions[c].cast<double>() - p0);
          if (bare & PhysicalMesh::kFrontBare) {
            ASSERT_LE(height, 1e-5) << "mesh " << m;
          }
          if (bare & PhysicalMesh::kBackBare) {
            ASSERT_GE(height, -1e-5) << "mesh " << m;
          }
        }
      }
    }
  }
  const size_t floor = 0, torus = 1, ball = 2, box = 3;
  EXPECT_EQ(front[floor], scene.meshes()[floor].triangles.size());
  EXPECT_EQ(back[floor], scene.meshes()[floor].triangles.size());
  EXPECT_GT(front[torus], scene.meshes()[torus].triangles.size() / 4);
  EXPECT_LT(front[torus], scene.meshes()[torus].triangles.size() * 3 / 4);
  EXPECT_EQ(back[torus], 0u);
  EXPECT_EQ(front[ball], scene.meshes()[ball].triangles.size());
  EXPECT_EQ(back[ball], 0u);
  EXPECT_EQ(front[box], scene.meshes()[box].triangles.size());
  EXPECT_EQ(back[box], 0u);
}

// Every ray through a core (Embree's own answer, the mesh alone in its scene) is blocked by the
// mesh, from outside and from inside it.
void expectCoresBlock(const Mesh& shape, const Eigen::Affine3d& placed, int expectedCores) {
  Scene scene;
  const int white = scene.addMaterial(Material::makeDiffuse({0.7f, 0.7f, 0.7f}));
  Mesh mesh = shape;
  mesh.material = white;
  scene.addMesh(std::move(mesh), true, placed);
  scene.addLight(Light::makeDirectional({0.2, -1.0, -0.3}, {1.0f, 1.0f, 1.0f}));
  scene.worldBox = Box3{{-1.5, -1.5, -1.5}, {1.5, 1.5, 1.5}};
  const PhysicalScene physical(scene, smallDisplay().model.displayableBox);
  ASSERT_EQ(physical.occluders().size(), 1u) << shape.name;
  const OccluderBound& bound = physical.occluders()[0];
  ASSERT_EQ(bound.coreCount, expectedCores) << shape.name;
  std::mt19937 random(5);
  std::normal_distribution<float> gaussian;
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int c = 0; c < bound.coreCount; ++c) {
    const Eigen::Vector4f core = bound.cores[static_cast<size_t>(c)];
    ASSERT_GT(core.w(), 0.0f);
    for (int i = 0; i < 500; ++i) {
      const Eigen::Vector3f l =
          Eigen::Vector3f(gaussian(random), gaussian(random), gaussian(random)).normalized();
      // A point of the core's disc across l; the ray starts a scene's width back, or (every
      // fourth) inside the core, and leaves through a back face.
      const Eigen::Vector3f across =
          Eigen::Vector3f(gaussian(random), gaussian(random), gaussian(random))
              .cross(l)
              .normalized();
      const Eigen::Vector3f through =
          core.head<3>() + 0.999f * core.w() * std::sqrt(unit(random)) * across;
      const Eigen::Vector3f origin =
          i % 4 == 0 ? through - 0.5f * core.w() * l : through - 1.5f * l;
      RTCRay ray;
      ray.org_x = origin.x();
      ray.org_y = origin.y();
      ray.org_z = origin.z();
      ray.dir_x = l.x();
      ray.dir_y = l.y();
      ray.dir_z = l.z();
      ray.tnear = 0.0f;
      ray.tfar = std::numeric_limits<float>::infinity();
      ray.time = 0.0f;
      ray.mask = 0xFFFFFFFFu;
      ray.id = 0;
      ray.flags = 0;
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      rtcOccluded1(physical.handle(), &context, &ray);
      ASSERT_EQ(ray.tfar, -std::numeric_limits<float>::infinity())
          << shape.name << ", core " << c << ", ray " << i;
    }
  }
}

// A closed convex mesh gets one core (a UV sphere, a box; its corners welded where they repeat),
// a torus its own beads along its core circle, turned and scaled alike; an open or flat mesh, a
// non-uniformly scaled torus and glass none.
TEST(ShadowRayBounds, CoresLieInsideClosedMeshes) {
  const Eigen::Affine3d turned = Eigen::Translation3d(0.1, 0.2, -0.1) *
                                 Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()) *
                                 Eigen::Scaling(1.3);
  expectCoresBlock(makeSphere(0.4, 24, 12), turned, 1);
  expectCoresBlock(makeSphere(0.4, 5, 3), Eigen::Affine3d::Identity(), 1);
  expectCoresBlock(makeBox({0.5, 0.3, 0.8}), turned, 1);
  expectCoresBlock(makeTorus(0.5, 0.15, 24, 12), turned, 24);
  expectCoresBlock(makeTorus(0.5, 0.2, 48, 6), Eigen::Affine3d::Identity(), 24);
  expectCoresBlock(makeTorus(0.5, 0.15, 5, 4), turned, 5);
  expectCoresBlock(makeTorus(0.5, 0.15, 24, 12), Eigen::Affine3d(Eigen::Scaling(1.0, 1.5, 1.0)), 0);
  expectCoresBlock(makeGrid(1.0, 1.0, 2, 2), turned, 0);
  expectCoresBlock(makeCone(0.4, 0.6, 24), turned, 1);

  // The beads are as wide as the tube allows: most of the torus's shadow is left to them.
  const Mesh torus = makeTorus(0.5, 0.15, 24, 12);
  ASSERT_EQ(torus.interior.size(), 24u);
  for (const Eigen::Vector4d& bead : torus.interior) {
    EXPECT_GT(bead.w(), 0.9 * 0.15);
    EXPECT_LT(bead.w(), 0.15);
  }
  // Glass lets light through (in a scene with a lit surface to shadow): no core.
  Scene scene;
  const int white = scene.addMaterial(Material::makeDiffuse({0.7f, 0.7f, 0.7f}));
  const int glass = scene.addMaterial(Material::makeDielectric(1.5f));
  Mesh floor = makeGrid(2.0, 2.0, 2, 2);
  floor.material = white;
  scene.addMesh(std::move(floor), true, Eigen::Affine3d(Eigen::Translation3d(0, -0.5, 0)));
  Mesh ball = makeSphere(0.4, 24, 12);
  ball.material = glass;
  scene.addMesh(std::move(ball));
  scene.addLight(Light::makeDirectional({0.2, -1.0, -0.3}, {1.0f, 1.0f, 1.0f}));
  scene.worldBox = Box3{{-1.5, -1.5, -1.5}, {1.5, 1.5, 1.5}};
  const PhysicalScene physical(scene, smallDisplay().model.displayableBox);
  ASSERT_TRUE(physical.glassShadows());
  ASSERT_EQ(physical.occluders().size(), 2u);
  EXPECT_FALSE(physical.occluders()[1].hasCore());
}

// More meshes than kMaxOccluders: no bounds, every ray traced.
TEST(ShadowRayBounds, ManyMeshesTraceEveryRay) {
  TempFolder folder;
  std::string text = R"(
local white = px.diffuse{color = {0.7, 0.7, 0.7}}
px.grid{width = 2, height = 2, material = white, transform = px.rotate_x(-math.pi / 2)}
px.directional{direction = {0.3, -1, -0.5}, color = {0.5, 0.5, 0.5}}
px.world_box{min = {-1, -0.1, -1}, max = {1, 1.5, 1}}
)";
  for (int i = 0; i < static_cast<int>(PhysicalScene::kMaxOccluders); ++i) {
    text += "px.box{size = {0.1, 0.1, 0.1}, material = white, transform = px.translate(" +
            std::to_string(-0.8 + 0.2 * i) + ", 0.3, 0)}\n";
  }
  ScriptOptions options;
  options.quiet = true;
  ScriptedScene script(folder.write("many.lua", text), options);
  const PhysicalScene scene(script.scene(), smallDisplay().model.displayableBox);
  EXPECT_EQ(scene.meshes().size(), PhysicalScene::kMaxOccluders + 1);
  EXPECT_TRUE(scene.occluders().empty());
  RenderCounters counters;
  renderFrame(scene, smallDisplay().textures[1], RenderOptions{}, &counters);
  EXPECT_GT(counters.shadow, 100);
  EXPECT_EQ(counters.shadowPassedBounds, 0);
}

}  // namespace
}  // namespace parallax
