// The daemon's display frame renders and encodes each module in one pass with a scratch frame
// per worker: its images must be byte for byte what rendering and encoding each module on its
// own gives, whatever the order the workers took the modules in.

#include "daemon/parallaxd/module_renderer.h"

#include <gtest/gtest.h>

#include "calibration/display/display_presets.h"
#include "tracer/scene_fixtures.h"

namespace parallax::daemon {
namespace {

TEST(ModuleRenderer, FusedRenderAndEncodeMatchesEachModuleAlone) {
  NominalDisplayOptions display;
  display.preset = "demo";
  display.modules = 6;
  display.width = 96;
  display.height = 72;
  const DisplayModel model = makeNominalDisplay(display);
  const PhysicalScene scene(makeShapesScene(), model.displayableBox);
  std::vector<RayTextures> textures;
  for (int i = 0; i < display.modules; ++i) textures.push_back(generateRayTextures(model, i));
  for (int round = 0; round < 2; ++round) {  // the second round reuses the workers' scratch frames
    const DisplayFrame frame = renderDisplayFrame(scene, textures, RenderOptions{});
    ASSERT_EQ(frame.images.size(), textures.size());
    RenderCounters expectedCounters;
    for (size_t i = 0; i < textures.size(); ++i) {
      RenderCounters counters;
      const Frame alone = renderFrame(scene, textures[i], RenderOptions{}, &counters);
      expectedCounters += counters;
      ASSERT_TRUE(frame.images[i]);
      EXPECT_EQ(frame.images[i]->pixels, encodeForLink(alone)->pixels)
          << "module " << i << ", round " << round;
    }
    EXPECT_EQ(frame.counters.rays(), expectedCounters.rays());
    EXPECT_GT(frame.counters.primary, 0);
    EXPECT_GE(frame.renderMs, 0.0);
    EXPECT_GE(frame.encodeMs, 0.0);
  }
}

// With a photometric correction installed every module is encoded through its own encoder;
// without one, exactly the sRGB encode of before.
TEST(ModuleRenderer, EachModuleIsEncodedThroughItsCorrection) {
  NominalDisplayOptions display;
  display.preset = "demo";
  display.modules = 3;
  display.width = 64;
  display.height = 48;
  const DisplayModel model = makeNominalDisplay(display);
  const PhysicalScene scene(makeShapesScene(), model.displayableBox);
  std::vector<RayTextures> textures;
  std::vector<ModuleEncoder> encoders;
  for (int i = 0; i < display.modules; ++i) {
    textures.push_back(generateRayTextures(model, i));
    ModuleColourCorrection c = ModuleColourCorrection::srgbIdentity();
    c.driveFromContent *= 0.6f + 0.1f * static_cast<float>(i);  // each module dimmed its own way
    encoders.emplace_back(c, 64, 48);
  }
  const DisplayFrame corrected = renderDisplayFrame(scene, textures, RenderOptions{}, encoders);
  const DisplayFrame plain = renderDisplayFrame(scene, textures, RenderOptions{});
  for (size_t i = 0; i < textures.size(); ++i) {
    const Frame alone = renderFrame(scene, textures[i], RenderOptions{});
    EXPECT_EQ(corrected.images[i]->pixels, encoders[i].encode(alone)) << "module " << i;
    EXPECT_EQ(plain.images[i]->pixels, alone.toSrgb8()) << "module " << i;
    EXPECT_NE(corrected.images[i]->pixels, plain.images[i]->pixels) << "module " << i;
  }
  EXPECT_THROW(
      renderDisplayFrame(scene, textures, RenderOptions{},
                         std::vector<ModuleEncoder>(encoders.begin(), encoders.begin() + 2)),
      std::invalid_argument);
}

}  // namespace
}  // namespace parallax::daemon
