// The tracer's SIMD kernels (Highway, chosen at run time) draw the same frame, bit for bit,
// whichever instruction set runs them: each target this machine supports is forced in turn
// (scalar, SSE4, AVX2, AVX-512, ...). A fused multiply-add, a reordered sum or an approximate
// reciprocal in one target's code would show here as a pixel that differs.

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <vector>

#include "calibration/display/display_presets.h"
#include "tracer/physical_scene.h"
#include "tracer/scene_fixtures.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

// Shapes (glass, Phong highlights, directional lights) with point lights added and one
// highlight's exponent made fractional (the std::pow lanes).
Scene kernelScene() {
  Scene scene = makeShapesScene();
  scene.addLight(Light::makePoint({0.2, 1.5, 1.0}, {0.8f, 0.8f, 0.7f}));
  scene.addLight(Light::makePoint({-0.6, 0.7, 0.8}, {0.5f, 0.4f, 0.4f}));
  bool fractional = false;
  for (Material& m : scene.materials) {
    if (m.specular.maxCoeff() > 0.0f && !fractional) {
      m.shininess = 20.5f;
      fractional = true;
    }
  }
  EXPECT_TRUE(fractional);
  return scene;
}

struct TargetGuard {
  ~TargetGuard() { hwy::SetSupportedTargetsForTest(0); }  // back to what the CPU has
};

// Each target's frames of `display`'s module 1, in the order of `targets`.
std::vector<Frame> framePerTarget(const DisplayModel& display,
                                  const std::vector<int64_t>& targets) {
  const PhysicalScene physical(kernelScene(), display.displayableBox);
  const RayTextures textures = generateRayTextures(display, 1);
  TargetGuard guard;
  std::vector<Frame> frames;
  for (int64_t target : targets) {
    hwy::SetSupportedTargetsForTest(target);
    RenderCounters counters;
    frames.push_back(renderFrame(physical, textures, RenderOptions{}, &counters));
    EXPECT_GT(counters.shadow, 1000) << hwy::TargetName(target);
    EXPECT_GT(counters.missedBounds, 100) << hwy::TargetName(target);
  }
  return frames;
}

TEST(SimdKernels, EveryInstructionSetDrawsTheSameFrame) {
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  // At least the portable one and one x86 vector set on any x86-64 machine.
  ASSERT_GE(targets.size(), 2u);
  // A flat screen, and a curved one (the primary rays' sag). 150 pixels a row: rows end in a
  // partial vector on every target.
  for (double curvature : {0.0, 0.8}) {
    NominalDisplayOptions options;
    options.preset = "demo";
    options.modules = 3;
    options.width = 150;
    options.height = 100;
    options.curvature = curvature;
    const std::vector<Frame> frames = framePerTarget(makeNominalDisplay(options), targets);
    for (size_t t = 1; t < frames.size(); ++t) {
      long differing = 0;
      for (size_t i = 0; i < frames[0].pixels.size(); ++i)
        differing += frames[t].pixels[i] == frames[0].pixels[i] ? 0 : 1;
      EXPECT_EQ(differing, 0) << hwy::TargetName(targets[t]) << " against "
                              << hwy::TargetName(targets[0]) << ", curvature " << curvature;
    }
  }
}

}  // namespace
}  // namespace parallax
