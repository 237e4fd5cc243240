// The frame cache (tracer/frame_cache.h) against a full re-trace: frame after frame of animated
// scripts, the 8-bit images the modules would show must be the same (issue 22: identical, or
// within one code value on at most 0.01% of the pixels). The scripts move what the cache holds
// static, move and recolour lights, hide objects, change the world box and reload with other
// geometry, so each way the records can go stale is met.

#include "tracer/frame_cache.h"

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
#include "script_test_util.h"
#include "scripts/scripted_scene.h"
#include "small_display.h"
#include "tracer/frame.h"
#include "tracer/physical_scene.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

using testing::TempFolder;

using Display = testing::SmallDisplay;

const Display& smallDisplay() {
  static const Display display = testing::makeSmallDisplay(128);
  return display;
}

struct Comparison {
  long pixels = 0;
  long differing = 0;  // pixels with any channel off
  int worst = 0;       // largest difference of a channel, in code values
  long cachedFrames = 0;
  RenderCounters counters;  // of the cached frames
};

// Renders the scene's current state both ways and compares what the modules would show.
// Returns whether the frame went through the cache.
bool compareFrame(const Scene& scene, FrameCache* cache, Comparison* out) {
  const Display& display = smallDisplay();
  const RenderOptions options;
  const PhysicalScene full(scene, display.model.displayableBox);
  PhysicalScene split(scene, display.model.displayableBox, &cache->dynamicInstances(scene));
  const bool cached = cache->prepare(split, display.textures, 1, options);
  out->cachedFrames += cached ? 1 : 0;
  for (size_t m = 0; m < display.textures.size(); ++m) {
    const Frame reference = renderFrame(full, display.textures[m], options);
    Frame frame;
    RenderCounters counters;
    if (cached) {
      renderFrameInto(split, display.textures[m], options, cache->view(m), &frame, &counters);
      out->counters += counters;
    } else {
      renderFrameInto(split, display.textures[m], options, &frame);
    }
    const std::vector<std::uint8_t> a = reference.toSrgb8(), b = frame.toSrgb8();
    EXPECT_EQ(a.size(), b.size());
    if (a.size() != b.size()) return cached;
    for (size_t p = 0; p < a.size(); p += 3) {
      int worst = 0;
      for (size_t k = 0; k < 3; ++k)
        worst = std::max(worst, std::abs(int{a[p + k]} - int{b[p + k]}));
      ++out->pixels;
      out->differing += worst > 0 ? 1 : 0;
      out->worst = std::max(out->worst, worst);
    }
  }
  return cached;
}

// `costs` (cached, full re-trace): each frame's CPU ms as reported to the cache's trial;
// without them nothing is reported and every frame goes through the cache.
struct Costs {
  double cached = 0.0, full = 0.0;
};

Comparison playAndCompare(ScriptedScene& script, int frames, double dt, FrameCache* cache,
                          const Costs* costs = nullptr) {
  Comparison c;
  for (int f = 0; f < frames; ++f) {
    EXPECT_TRUE(script.setTime(f * dt)) << script.lastError();
    const bool cached = compareFrame(script.scene(), cache, &c);
    if (costs) cache->reportFrameCost(cached ? costs->cached : costs->full);
  }
  return c;
}

void expectSameImages(const Comparison& c) {
  EXPECT_GT(c.pixels, 0);
  // Identical but for the rare pixel whose static hit is recomputed a few ulps away from
  // Embree's distance (the texture footprint) or whose ray starts elsewhere because the moving
  // objects widened the scene's bounds: at most one code value, at most 0.01% of the pixels.
  EXPECT_LE(c.worst, 1) << c.differing << " of " << c.pixels << " pixels differ";
  EXPECT_LE(c.differing * 10000, c.pixels) << c.differing << " of " << c.pixels;
}

// The script file played frame by frame, each frame rendered with the cache and by a full
// re-trace: the same images expected; what was compared returned for the test's own checks.
Comparison playExpectingSameImages(const std::string& path, int frames, double dt,
                                   FrameCache* cache) {
  ScriptedScene script(path, testing::libraryOptions());
  const Comparison c = playAndCompare(script, frames, dt, cache);
  expectSameImages(c);
  return c;
}

TEST(FrameCache, OrbitFramesEqualAFullRetrace) {
  FrameCache cache;
  const Comparison c =
      playExpectingSameImages(testing::sceneLibrary() + "/orbit.lua", 30, 0.13, &cache);
  // The cache was used and saved work: one build, the floor and wall static, three of the
  // four lights static (the key light turns).
  EXPECT_EQ(cache.stats().builds, 1);
  EXPECT_EQ(c.cachedFrames, 30);
  EXPECT_EQ(cache.stats().staticInstances, 2);
  EXPECT_EQ(cache.stats().cachedLights, 3);
  EXPECT_GT(c.counters.cache.pixelsReused, c.counters.primary / 2);
  EXPECT_GT(c.counters.cache.shadowAnswered + c.counters.cache.shadowDynamicOnly, 0);
  EXPECT_EQ(cache.stats().bytesPerPixel(), 12.0);
}

// The cache's good case: two models, a pedestal and a mirror floor stand still, one ball moves
// (hits on the static mirror are taken from the cache, their reflections traced in full).
TEST(FrameCache, SentinelFramesEqualAFullRetrace) {
  FrameCache cache;
  const Comparison c =
      playExpectingSameImages(testing::sceneLibrary() + "/sentinel.lua", 10, 0.4, &cache);
  EXPECT_EQ(cache.stats().builds, 1);
  EXPECT_EQ(cache.stats().dynamicInstances, 1);
  EXPECT_EQ(cache.stats().cachedLights, 4);
  // Half the primary rays pass between the objects inside the scene's bounds: no hit at all.
  EXPECT_GT(c.counters.cache.pixelsReused, c.counters.primary / 3);
}

// A floor that starts to move after a while, a pillar that is moved by assigning its
// transform through a second handle, a light that turns late, a point light that moves, a
// light that only changes colour, static glass (its shadows are never cached), an object
// hidden by moving it out of the world box.
const char* const kRestless = R"(
local white = px.diffuse{color = {0.7, 0.7, 0.7}}
local red = px.phong{color = {0.8, 0.2, 0.2}, specular = {0.5, 0.5, 0.5}, shininess = 20}
local glass = px.glass{ior = 1.5, absorption = {0.5, 0.2, 0.1}}
local floor = px.grid{width = 2, height = 2, nx = 4, ny = 4, material = white,
                      transform = px.rotate_x(-math.pi / 2)}
local back = px.plane{width = 2, height = 1.5, material = white,
                      transform = px.translate(0, 0.75, -1)}
px.box{size = {0.3, 0.3, 0.3}, material = glass, transform = px.translate(0.5, 0.3, 0.2)}
local pillar = px.cylinder{radius = 0.1, height = 0.8, material = red,
                           transform = px.translate(-0.5, 0.4, 0)}
local ball = px.sphere{radius = 0.15, material = red, transform = px.translate(0, 0.5, 0.3)}
local sun = px.directional{direction = {0.3, -1, -0.5}, color = {0.5, 0.5, 0.5}}
local side = px.directional{direction = {-0.5, -0.6, -0.4}, color = {0.3, 0.3, 0.3}}
local bulb = px.point{position = {0, 1.2, 0.5}, color = {0.4, 0.4, 0.4}}
local tint = px.directional{direction = {0, -0.5, -1}, color = {0.2, 0.2, 0.2}}
px.world_box{min = {-1, -0.1, -1}, max = {1, 1.5, 1}}
function update(t, dt)
  px.set_transform(ball, px.translate(0.4 * math.cos(t), 0.5, 0.3 * math.sin(t)))
  if t > 1 then px.set_transform(floor, px.translate(0, 0.05 * math.sin(t), 0) * px.rotate_x(-math.pi / 2)) end
  if t > 2 then px.set_transform(pillar, px.translate(-0.5, 0.4, 0) * px.rotate_z(0.2 * (t - 2))) end
  if t > 2.5 then px.set_transform(ball, px.translate(5, 5, 5)) end
  if t > 1.5 then px.set_light(side, {direction = {-0.5, -0.6, -0.4 + 0.1 * t}}) end
  px.set_light(bulb, {position = {0.3 * math.sin(t), 1.2, 0.5}})
  px.set_light(tint, {color = {0.2 + 0.1 * math.sin(t), 0.2, 0.2}})
end
)";

TEST(FrameCache, ScriptsThatMoveStaticThingsAndLightsStillRenderCorrectly) {
  TempFolder folder;
  FrameCache cache;
  const Comparison c =
      playExpectingSameImages(folder.write("restless.lua", kRestless), 30, 0.12, &cache);
  // The floor and the pillar joined the dynamic objects when they first moved: built again.
  EXPECT_GE(cache.stats().builds, 3);
  EXPECT_GT(c.counters.cache.pixelsReused, 0);
  EXPECT_EQ(cache.stats().staticInstances, 2);  // the back wall and the glass box
}

// Without a world box the scene's bounds follow the moving ball: every static vertex moves in
// physical space every frame. The cache must notice (and stop rebuilding every frame).
const char* const kNoWorldBox = R"(
local white = px.diffuse{color = {0.7, 0.7, 0.7}}
px.grid{width = 2, height = 2, nx = 2, ny = 2, material = white, transform = px.rotate_x(-1.2)}
local ball = px.sphere{radius = 0.2, material = white}
px.directional{direction = {0.3, -1, -0.5}, color = {0.6, 0.6, 0.6}}
function update(t, dt)
  px.set_transform(ball, px.translate(1.2 + 0.5 * t, 0.5, 0))
end
)";

TEST(FrameCache, AWorldBoxThatFollowsTheMotionBypassesTheCache) {
  TempFolder folder;
  FrameCache cache;
  playExpectingSameImages(folder.write("drifting.lua", kNoWorldBox), 20, 0.2, &cache);
  EXPECT_LT(cache.stats().builds, 8);
  EXPECT_GT(cache.stats().framesBypassed, 10);
}

std::string reloadable(const std::string& width, const std::string& extra) {
  return R"(
local white = px.diffuse{color = {0.7, 0.7, 0.7}}
px.grid{width = )" +
         width + R"(, height = 2, nx = 2, ny = 2, material = white,
        transform = px.rotate_x(-1.2)}
local ball = px.sphere{radius = 0.2, material = white}
px.directional{direction = {0.3, -1, -0.5}, color = {0.6, 0.6, 0.6}}
px.world_box{min = {-1.2, -1.2, -1.2}, max = {1.2, 1.2, 1.2}}
)" + extra +
         R"(
function update(t, dt)
  px.set_transform(ball, px.translate(0.6 * math.cos(t), 0.4, 0.6 * math.sin(t)))
end
)";
}

TEST(FrameCache, AReloadWithOtherGeometryRebuildsIt) {
  TempFolder folder;
  const std::string path = folder.write("scene.lua", reloadable("2", ""));
  ScriptedScene script(path, testing::libraryOptions());
  FrameCache cache;
  Comparison c = playAndCompare(script, 5, 0.2, &cache);
  EXPECT_EQ(cache.stats().builds, 1);
  // The same objects, one of them larger: the layout is the same, the geometry is not.
  folder.write("scene.lua", reloadable("2.2", ""));
  ASSERT_EQ(script.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  const Comparison resized = playAndCompare(script, 5, 0.2, &cache);
  EXPECT_EQ(cache.stats().builds, 2);
  // An object added.
  folder.write("scene.lua", reloadable("2.2", "px.box{size = {0.4, 0.4, 0.4}, material = white}"));
  ASSERT_EQ(script.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  const Comparison added = playAndCompare(script, 5, 0.2, &cache);
  EXPECT_EQ(cache.stats().builds, 3);
  expectSameImages(c);
  expectSameImages(resized);
  expectSameImages(added);
}

// The cached frame's SIMD kernels (static_hit_kernel.h: the static hits turned back into
// distances, the sphere tests, the hits written back) give every instruction set the same
// frames, bit for bit: each target this machine supports is forced in turn.
TEST(FrameCache, EveryInstructionSetDrawsTheSameCachedFrames) {
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  ASSERT_GE(targets.size(), 2u);
  struct TargetGuard {
    ~TargetGuard() { hwy::SetSupportedTargetsForTest(0); }  // back to what the CPU has
  } guard;
  ScriptedScene script(testing::sceneLibrary() + "/orbit.lua", testing::libraryOptions());
  FrameCache cache;
  const Display& display = smallDisplay();
  const RenderOptions options;
  for (double time : {0.0, 0.7, 1.9}) {
    ASSERT_TRUE(script.setTime(time)) << script.lastError();
    PhysicalScene split(script.scene(), display.model.displayableBox,
                        &cache.dynamicInstances(script.scene()));
    ASSERT_TRUE(cache.prepare(split, display.textures, 1, options));
    for (size_t m = 0; m < display.textures.size(); ++m) {
      std::vector<Frame> frames;
      for (int64_t target : targets) {
        hwy::SetSupportedTargetsForTest(target);
        Frame frame;
        RenderCounters counters;
        renderFrameInto(split, display.textures[m], options, cache.view(m), &frame, &counters);
        EXPECT_GT(counters.cache.pixelsReused, 0) << hwy::TargetName(target);
        EXPECT_GT(counters.cache.primaryPassedDynamic, 0) << hwy::TargetName(target);
        frames.push_back(std::move(frame));
      }
      for (size_t t = 1; t < frames.size(); ++t) {
        long differing = 0;
        for (size_t p = 0; p < frames[0].pixels.size(); ++p)
          differing += frames[t].pixels[p] == frames[0].pixels[p] ? 0 : 1;
        EXPECT_EQ(differing, 0) << hwy::TargetName(targets[t]) << " against "
                                << hwy::TargetName(targets[0]) << ", t " << time << ", module "
                                << m;
      }
    }
  }
}

// orbit.lua's cache saves next to nothing (its key light turns, its moving objects are most of
// its triangles): once the trial has timed frames both ways and the re-traces cost under
// kMinGain times the cached ones, the records are freed and frames are rendered in full.
TEST(FrameCache, RecordsThatDoNotPayAreFreedAndTheFramesStayExact) {
  ScriptedScene script(testing::sceneLibrary() + "/orbit.lua", testing::libraryOptions());
  FrameCache cache;
  const Costs costs{100.0, 104.0};  // 1.04x: under the 1.1x it must save
  const Comparison c = playAndCompare(script, 12, 0.13, &cache, &costs);
  expectSameImages(c);
  const FrameCacheStats& s = cache.stats();
  EXPECT_EQ(s.builds, 1);
  EXPECT_TRUE(s.declined);
  EXPECT_EQ(s.bytes, 0u);
  EXPECT_EQ(s.bytesFreed, 3u * 128u * 96u * sizeof(StaticHit));
  EXPECT_EQ(s.framesMeasured, FrameCache::kTrialFrames);
  // The build's frame and the trial's cached ones; every frame after the decision in full.
  EXPECT_EQ(c.cachedFrames, 1 + FrameCache::kTrialFrames);
  EXPECT_EQ(s.payoff.rfind("does not pay: 100.0 ms CPU a frame through it, 104.0 ms without", 0),
            0u)
      << s.payoff;
  bool said = false;
  for (const std::string& line : s.lines()) said = said || line.find("does not pay") != line.npos;
  EXPECT_TRUE(said);
}

TEST(FrameCache, RecordsThatPayAreKept) {
  ScriptedScene script(testing::sceneLibrary() + "/sentinel.lua", testing::libraryOptions());
  FrameCache cache;
  const Costs costs{100.0, 150.0};
  const Comparison c = playAndCompare(script, 10, 0.4, &cache, &costs);
  expectSameImages(c);
  const FrameCacheStats& s = cache.stats();
  EXPECT_FALSE(s.declined);
  EXPECT_EQ(s.bytesFreed, 0u);
  EXPECT_GT(s.bytes, 0u);
  EXPECT_EQ(s.payoff.rfind("pays: 100.0 ms CPU a frame through it, 150.0 ms without (1.50x", 0), 0u)
      << s.payoff;
  // Only the trial's full re-traces bypassed it.
  EXPECT_EQ(c.cachedFrames, 10 - FrameCache::kTrialFrames);
}

// Records that did not pay are tried again when what they were built for changes.
TEST(FrameCache, ASceneChangeAfterADeclineBuildsAndMeasuresAgain) {
  TempFolder folder;
  const std::string path = folder.write("scene.lua", reloadable("2", ""));
  ScriptedScene script(path, testing::libraryOptions());
  FrameCache cache;
  const Costs equal{100.0, 100.0};
  const Comparison before = playAndCompare(script, 10, 0.2, &cache, &equal);
  EXPECT_TRUE(cache.stats().declined);
  EXPECT_EQ(cache.stats().builds, 1);
  folder.write("scene.lua", reloadable("2.2", ""));
  ASSERT_EQ(script.reloadIfChanged(), ScriptedScene::Reload::kReloaded);
  const Costs cheaper{100.0, 200.0};
  const Comparison after = playAndCompare(script, 10, 0.2, &cache, &cheaper);
  EXPECT_EQ(cache.stats().builds, 2);
  EXPECT_EQ(cache.stats().lastRebuild, "the scene changed since the cache did not pay");
  EXPECT_FALSE(cache.stats().declined);
  EXPECT_GT(cache.stats().bytes, 0u);
  expectSameImages(before);
  expectSameImages(after);
}

}  // namespace
}  // namespace parallax
