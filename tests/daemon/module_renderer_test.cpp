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

}  // namespace
}  // namespace parallax::daemon
