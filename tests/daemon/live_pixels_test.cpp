// Frames of animated scenes through LivePixels (only the scene's footprint traced and encoded,
// the rest copied from the backdrop) against the full render and encode of the same scene: the
// modules must be sent the same bytes, and the counters must say the same, whatever moves, with
// or without a photometric correction, when the scene leaves the box the footprint was made for
// and while the earlier frames' images are still held (their buffers are recycled).

#include "daemon/parallaxd/live_pixels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include "calibration/display/display_presets.h"
#include "daemon/parallaxd/module_renderer.h"
#include "scripts/scripted_scene.h"
#include "tests/scripts/script_test_util.h"
#include "tests/scripts/small_display.h"

namespace parallax::daemon {
namespace {

using Display = testing::SmallDisplay;

const Display& smallDisplay() {
  static const Display display = testing::makeSmallDisplay(128, 4);
  return display;
}

// Each module dimmed, lifted and vignetted its own way: the backdrop's black and background
// bytes differ from pixel to pixel.
std::vector<ModuleEncoder> correctedEncoders() {
  std::vector<ModuleEncoder> encoders;
  for (int i = 0; i < 4; ++i) {
    ModuleColourCorrection c = ModuleColourCorrection::srgbIdentity();
    c.driveFromContent *= 0.6f + 0.1f * static_cast<float>(i);
    c.lift = Eigen::Vector3f(0.02f, 0.03f, 0.01f * static_cast<float>(i + 1));
    c.gainWidth = 2;
    c.gainHeight = 2;
    c.gain = {1.0f, 1.3f, 1.1f, 1.6f};
    encoders.emplace_back(c, 128, 96);
  }
  return encoders;
}

struct Played {
  int frames = 0;
  long outside = 0;  // pixels outside the footprints, all frames
  long pixels = 0;
};

// Whether two images are equal outside `spans` (the bytes their family says may differ).
bool equalOutside(const hw::Image& a, const hw::Image& b, const hw::ImageRegions& regions) {
  if (a.pixels.size() != b.pixels.size()) return false;
  size_t from = 0;
  const auto same = [&](size_t begin, size_t end) {
    return std::equal(a.pixels.begin() + static_cast<std::ptrdiff_t>(begin),
                      a.pixels.begin() + static_cast<std::ptrdiff_t>(end),
                      b.pixels.begin() + static_cast<std::ptrdiff_t>(begin));
  };
  for (const auto& [begin, end] : regions.spans) {
    if (!same(from, begin)) return false;
    from = end;
  }
  return same(from, a.pixels.size());
}

// Plays the script frame by frame, each frame both ways. With `holdEarlier` every earlier
// frame's images are kept (as the conductor and the link hold them) and must not change
// afterwards; without, they are let go and their buffers come back, the last frame's pixels
// inside the footprint.
Played playBothWays(ScriptedScene& script, int frames, double dt,
                    const std::vector<ModuleEncoder>& encoders, LivePixels* live,
                    bool holdEarlier = true) {
  const Display& display = smallDisplay();
  Played played;
  std::vector<std::vector<std::shared_ptr<const hw::Image>>> held;
  // Per module, the first image of the family the last one belongs to (its bytes copied).
  std::vector<std::pair<std::uint64_t, std::vector<std::uint8_t>>> familyFirst(
      display.textures.size());
  std::vector<std::vector<std::vector<std::uint8_t>>> heldBytes;
  for (int f = 0; f < frames; ++f) {
    EXPECT_TRUE(script.setTime(f * dt)) << script.lastError();
    const PhysicalScene scene(script.scene(), display.model.displayableBox);
    live->prepare(scene, display.textures, 1, encoders, 1);
    const DisplayFrame fast =
        renderDisplayFrame(scene, display.textures, RenderOptions{}, encoders, nullptr, live);
    const DisplayFrame full =
        renderDisplayFrame(scene, display.textures, RenderOptions{}, encoders);
    for (size_t i = 0; i < display.textures.size(); ++i) {
      EXPECT_EQ(fast.images[i]->pixels, full.images[i]->pixels) << "frame " << f << " module " << i;
      // What the link may leave out of a patch: every image of a family has the same bytes
      // outside its regions.
      const hw::Image& image = *fast.images[i];
      EXPECT_TRUE(image.regions) << "frame " << f << " module " << i;
      if (!image.regions) continue;
      auto& [family, first] = familyFirst[i];
      if (family != image.regions->family) {
        family = image.regions->family;
        first = image.pixels;
      } else {
        hw::Image earlier = image;
        earlier.pixels = first;
        EXPECT_TRUE(equalOutside(image, earlier, *image.regions))
            << "frame " << f << " module " << i;
      }
      EXPECT_EQ(fast.images[i]->width, full.images[i]->width);
      EXPECT_EQ(fast.images[i]->height, full.images[i]->height);
    }
    EXPECT_EQ(fast.counters.pixels, full.counters.pixels) << "frame " << f;
    EXPECT_EQ(fast.counters.masked, full.counters.masked) << "frame " << f;
    EXPECT_EQ(fast.counters.missedBounds, full.counters.missedBounds) << "frame " << f;
    EXPECT_EQ(fast.counters.rays(), full.counters.rays()) << "frame " << f;
    EXPECT_EQ(full.counters.outsideFootprint, 0);
    played.outside += fast.counters.outsideFootprint;
    played.pixels += fast.counters.pixels;
    ++played.frames;
    if (!holdEarlier) continue;
    held.push_back(fast.images);
    heldBytes.emplace_back();
    for (const auto& image : fast.images) heldBytes.back().push_back(image->pixels);
  }
  for (size_t f = 0; f < held.size(); ++f) {
    for (size_t i = 0; i < held[f].size(); ++i)
      EXPECT_EQ(held[f][i]->pixels, heldBytes[f][i]) << "frame " << f << " module " << i;
  }
  return played;
}

TEST(LivePixels, OrbitFramesAreThoseOfAFullRender) {
  ScriptedScene script(testing::sceneLibrary() + "/orbit.lua", testing::libraryOptions());
  LivePixels live;
  const Played p = playBothWays(script, 12, 0.37, {}, &live);
  EXPECT_EQ(p.frames, 12);
  // Most of a module lies outside the scene's footprint: that is the work saved.
  EXPECT_GT(p.outside, p.pixels / 2);
  EXPECT_LE(live.stats().builds, 3);
  EXPECT_LT(live.stats().livePixels, live.stats().pixels / 2);
  EXPECT_EQ(live.stats().backdropBytes, static_cast<size_t>(live.stats().pixels) * 3);
}

TEST(LivePixels, RecycledImagesAreWrittenWhole) {
  // Images let go are handed out again with the backdrop in place, not copied in afresh: every
  // pixel of the footprint must be written over, with each module's own correction.
  ScriptedScene script(testing::sceneLibrary() + "/orbit.lua", testing::libraryOptions());
  LivePixels live;
  const Played p = playBothWays(script, 10, 0.41, correctedEncoders(), &live, false);
  EXPECT_EQ(p.frames, 10);
  const LivePixelsStats stats = live.stats();
  EXPECT_GT(stats.recycledImages, 0);
  EXPECT_EQ(stats.recycledImages + stats.newImages, 10 * 4);
}

TEST(LivePixels, EachModuleKeepsItsOwnCorrection) {
  ScriptedScene script(testing::sceneLibrary() + "/orbit.lua", testing::libraryOptions());
  LivePixels live;
  const Played p = playBothWays(script, 6, 0.5, correctedEncoders(), &live);
  EXPECT_GT(p.outside, p.pixels / 2);
}

// A ball flies off to the side and comes back: the scene's bounds leave the footprint's box,
// which is made again around both (a few times, the margin doubling), never a wrong frame.
TEST(LivePixels, AScenePastItsBoxGetsANewFootprint) {
  testing::TempFolder folder;
  const std::string path = folder.write("flyaway.lua", R"(
px.name("flyaway")
local white = px.diffuse{name = "white", color = {0.8, 0.8, 0.8}}
local red = px.diffuse{name = "red", color = {0.9, 0.2, 0.1}}
px.grid{width = 1.0, height = 1.0, material = white, transform = px.rotate_x(-math.pi / 2)}
local ball = px.sphere{radius = 0.1, material = red, name = "ball"}
px.directional{direction = {0.3, -1.0, -0.4}, color = {1, 1, 1}}
px.background({0.1, 0.2, 0.3})
px.world_box{min = {-2, -0.5, -1}, max = {2, 1.5, 1}}
function update(t, dt)
  px.set_transform(ball, px.translate(1.6 * math.sin(t), 0.3 + 0.5 * t, 0))
end
)");
  ScriptedScene script(path, testing::libraryOptions());
  LivePixels live;
  const Played p = playBothWays(script, 10, 0.3, {}, &live);
  EXPECT_GT(live.stats().builds, 1);
  EXPECT_GT(p.outside, 0);
}

// New ray textures or encoders: the footprints and backdrops are made again.
TEST(LivePixels, NewTexturesOrEncodersMakeItAgain) {
  const Display& display = smallDisplay();
  ScriptedScene script(testing::sceneLibrary() + "/orbit.lua", testing::libraryOptions());
  ASSERT_TRUE(script.setTime(0.0));
  const PhysicalScene scene(script.scene(), display.model.displayableBox);
  LivePixels live;
  live.prepare(scene, display.textures, 1, {}, 1);
  live.prepare(scene, display.textures, 1, {}, 1);
  EXPECT_EQ(live.stats().builds, 1);
  live.prepare(scene, display.textures, 2, {}, 1);
  EXPECT_EQ(live.stats().builds, 2);
  const std::vector<ModuleEncoder> encoders = correctedEncoders();
  live.prepare(scene, display.textures, 2, encoders, 2);
  EXPECT_EQ(live.stats().builds, 3);
  const DisplayFrame fast =
      renderDisplayFrame(scene, display.textures, RenderOptions{}, encoders, nullptr, &live);
  const DisplayFrame full = renderDisplayFrame(scene, display.textures, RenderOptions{}, encoders);
  for (size_t i = 0; i < display.textures.size(); ++i)
    EXPECT_EQ(fast.images[i]->pixels, full.images[i]->pixels) << "module " << i;
  EXPECT_THROW(live.prepare(scene, display.textures, 2,
                            std::vector<ModuleEncoder>(encoders.begin(), encoders.begin() + 2), 3),
               std::invalid_argument);
}

}  // namespace
}  // namespace parallax::daemon
