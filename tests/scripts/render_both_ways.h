#pragma once
// A script played frame after frame, every module of a small display rendered with two sets of
// options: the tests of a shortcut that must give the frames the longer way gives, bit for bit
// (shadow-ray bounds, rays without the mesh they leave).

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "script_test_util.h"
#include "scripts/scripted_scene.h"
#include "small_display.h"
#include "tracer/frame.h"
#include "tracer/physical_scene.h"
#include "tracer/whitted_integrator.h"

namespace parallax::testing {

struct PixelTally {
  long pixels = 0;
  long differing = 0;  // compared as floats
};

// Frames at t = f · dt for f < frames of the script at `path` (the scene library's options),
// mapped into `display`; `eachFrame` sees each frame's scene, `eachModule` each module's counters
// both ways. Expects every pixel equal, naming the script.
inline PixelTally renderBothWays(
    const std::string& path, int frames, double dt, const SmallDisplay& display,
    const RenderOptions& a, const RenderOptions& b,
    const std::function<void(const PhysicalScene&)>& eachFrame,
    const std::function<void(const RenderCounters& a, const RenderCounters& b)>& eachModule) {
  ScriptedScene script(path, libraryOptions());
  PixelTally tally;
  for (int f = 0; f < frames; ++f) {
    EXPECT_TRUE(script.setTime(f * dt)) << script.lastError();
    const PhysicalScene scene(script.scene(), display.model.displayableBox);
    eachFrame(scene);
    for (const RayTextures& textures : display.textures) {
      RenderCounters countersA, countersB;
      const Frame frameA = renderFrame(scene, textures, a, &countersA);
      const Frame frameB = renderFrame(scene, textures, b, &countersB);
      for (size_t p = 0; p < frameA.pixels.size(); ++p) {
        ++tally.pixels;
        tally.differing += frameA.pixels[p] == frameB.pixels[p] ? 0 : 1;
      }
      eachModule(countersA, countersB);
    }
  }
  EXPECT_EQ(tally.differing, 0) << tally.differing << " of " << tally.pixels << " pixels, " << path;
  return tally;
}

}  // namespace parallax::testing
