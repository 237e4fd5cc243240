// The tracer's SIMD kernels (Highway, chosen at run time) draw the same frame, bit for bit,
// whichever instruction set runs them: each target this machine supports is forced in turn
// (scalar, SSE4, AVX2, AVX-512, ...). A fused multiply-add, a reordered sum or an approximate
// reciprocal in one target's code would show here as a pixel that differs. The same holds for
// the sRGB encode of a frame's channels.

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "calibration/display/display_presets.h"
#include "tracer/physical_scene.h"
#include "tracer/scene_fixtures.h"
#include "tracer/srgb_encode_kernel.h"
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
  // A finely textured floor: textured diffuse packets (uv, ray cone, mip level and trilinear
  // lookup in the kernel), with texels small enough that the footprint picks and blends mip
  // levels above the finest (a coarse texture would clamp every lookup to level 0, and the
  // cone would not show in the frame).
  Texture fine;
  fine.width = fine.height = 512;
  for (int i = 0; i < 512 * 512; ++i) {
    const std::uint32_t hash = static_cast<std::uint32_t>(i) * 2654435761u;
    for (int c = 0; c < 3; ++c)
      fine.pixels.push_back(0.1f + 0.8f * static_cast<float>((hash >> (8 * c)) & 255u) / 255.0f);
  }
  const int texture = scene.addTexture(fine);
  bool textured = false;
  for (const Mesh& mesh : scene.meshes) {
    if (mesh.name == "floor") {
      scene.materials[static_cast<size_t>(mesh.material)].diffuseTexture = texture;
      textured = true;
    }
  }
  EXPECT_TRUE(textured);
  return scene;
}

long differingPixels(const Frame& a, const Frame& b) {
  long differing = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) differing += a.pixels[i] == b.pixels[i] ? 0 : 1;
  return differing;
}

NominalDisplayOptions smallDemo(double curvature) {
  NominalDisplayOptions options;
  options.preset = "demo";
  options.modules = 3;
  options.width = 150;  // rows end in a partial vector on every target
  options.height = 100;
  options.curvature = curvature;
  return options;
}

struct TargetGuard {
  ~TargetGuard() { hwy::SetSupportedTargetsForTest(0); }  // back to what the CPU has
};

// The kernels' scene (glass: what its shadow rays carry through glass is folded in first), and
// the Cornell box (no glass); both add the first generation's light with the vector kernel.
std::vector<Scene> kernelScenes() { return {kernelScene(), makeCornellScene()}; }

// Each target's frames of `display`'s module 1, in the order of `targets`.
std::vector<Frame> framePerTarget(const Scene& scene, const DisplayModel& display,
                                  const std::vector<int64_t>& targets) {
  const PhysicalScene physical(scene, display.displayableBox);
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
  for (const Scene& scene : kernelScenes()) {
    for (double curvature : {0.0, 0.8}) {
      const std::vector<Frame> frames =
          framePerTarget(scene, makeNominalDisplay(smallDemo(curvature)), targets);
      for (size_t t = 1; t < frames.size(); ++t) {
        EXPECT_EQ(differingPixels(frames[t], frames[0]), 0)
            << hwy::TargetName(targets[t]) << " against " << hwy::TargetName(targets[0])
            << ", curvature " << curvature << ", " << scene.meshes.size() << " meshes";
      }
    }
  }
}

// The diffuse shading kernel (diffuse_hit_kernel.h, with the textured packets' lookups after it)
// and the shadow rays' gather and scatter (shadow_ray_kernel.h) draw what the scalar shade() and
// per-ray loop draw, bit for bit, on a flat and a curved screen.
TEST(SimdKernels, PacketShadingDrawsWhatScalarShadingDraws) {
  for (const Scene& scene : kernelScenes()) {
    const bool textured = !scene.textures.empty();
    for (double curvature : {0.0, 0.8}) {
      const DisplayModel display = makeNominalDisplay(smallDemo(curvature));
      const PhysicalScene physical(scene, display.displayableBox);
      EXPECT_EQ(physical.glassShadows(), textured) << "one scene of each kind";
      const RayTextures textures = generateRayTextures(display, 1);
      RenderOptions scalar;
      scalar.packetShading = false;
      RenderCounters packetCounters, scalarCounters;
      const Frame packets = renderFrame(physical, textures, RenderOptions{}, &packetCounters);
      const Frame reference = renderFrame(physical, textures, scalar, &scalarCounters);
      EXPECT_EQ(differingPixels(packets, reference), 0)
          << "curvature " << curvature << ", " << scene.meshes.size() << " meshes";
      if (textured) {
        EXPECT_GT(scalarCounters.textureLookups, 300) << "the floor is sampled";
      }
      EXPECT_GT(scalarCounters.shadow, 5000);
      EXPECT_EQ(packetCounters.textureLookups, scalarCounters.textureLookups);
      EXPECT_EQ(packetCounters.shadow, scalarCounters.shadow);
    }
  }
}

// The sRGB encode (srgb_encode_kernel.h) gives srgb8FromLinear's byte for every input on every
// target: a sweep of [0, 1] and beyond, the inputs on either side of every code boundary,
// negatives, infinities and NaN, in a frame whose channel count ends in a partial vector.
TEST(SimdKernels, EveryInstructionSetEncodesTheFormulasBytes) {
  std::vector<float> values;
  for (std::uint32_t bits = 0; bits <= std::bit_cast<std::uint32_t>(1.0f) + 1000; bits += 997)
    values.push_back(std::bit_cast<float>(bits));
  for (int k = 1; k < 256; ++k) {
    std::uint32_t lo = 0, hi = std::bit_cast<std::uint32_t>(1.0f);  // the boundary, by bisection
    while (lo < hi) {
      const std::uint32_t mid = lo + (hi - lo) / 2;
      if (srgb8FromLinear(std::bit_cast<float>(mid)) >= k)
        hi = mid;
      else
        lo = mid + 1;
    }
    for (std::uint32_t b = lo - 3; b <= lo + 3; ++b) values.push_back(std::bit_cast<float>(b));
  }
  // Around each edge between the table's bins (runs of 2^kShift float bit patterns).
  for (std::uint32_t bin = 1; bin <= std::bit_cast<std::uint32_t>(1.0f) >> SrgbTable::kShift;
       ++bin) {
    const std::uint32_t edge = bin << SrgbTable::kShift;
    for (std::uint32_t b = edge - 2; b <= edge + 2; ++b) values.push_back(std::bit_cast<float>(b));
  }
  const float inf = std::numeric_limits<float>::infinity();
  for (float v : {-1.0f, -0.0f, 2.0f, 1e30f, -inf, inf, std::numeric_limits<float>::quiet_NaN(),
                  -std::numeric_limits<float>::quiet_NaN()})
    values.push_back(v);
  while (values.size() % 3 != 0 || (values.size() / 3) % 16 == 0) values.push_back(0.5f);
  Frame frame(static_cast<int>(values.size() / 3), 1);
  for (size_t i = 0; i < values.size(); ++i)
    frame.pixels[i / 3][static_cast<int>(i % 3)] = values[i];

  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  ASSERT_GE(targets.size(), 2u);
  TargetGuard guard;
  for (int64_t target : targets) {
    hwy::SetSupportedTargetsForTest(target);
    const std::vector<std::uint8_t> bytes = frame.toSrgb8();
    ASSERT_EQ(bytes.size(), values.size());
    long differing = 0;
    for (size_t i = 0; i < values.size(); ++i) {
      if (bytes[i] != srgb8FromLinear(values[i]) && ++differing <= 3) {
        ADD_FAILURE() << hwy::TargetName(target) << ": linear " << values[i] << " gives "
                      << int{bytes[i]} << ", the formula " << int{srgb8FromLinear(values[i])};
      }
    }
    EXPECT_EQ(differing, 0) << hwy::TargetName(target);
  }
}

}  // namespace
}  // namespace parallax
