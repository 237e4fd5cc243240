#include "tracer/rasterizer.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/input_error.h"
#include "tests/tracer/tracer_test_util.h"
#include "tracer/direct_shading.h"
#include "tracer/position_error.h"
#include "tracer/scene_fixtures.h"
#include "tracer/supersampled_render.h"
#include "tracer/visibility_buffer.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

using test::smallDisplay;

// Everything the error of one module needs.
struct ModuleCase {
  ModuleCase(const DisplayModel& display, const Scene& scene, int module)
      : model(display),
        physical(scene, model.displayableBox),
        textures(generateRayTextures(model, module)),
        traced(tracePrimaryVisibility(physical, textures)),
        exact(exactSurface(physical, model, module, traced)),
        forwardMap(model, module),
        rasterizer(model, module) {}

  PositionError rasterError(int level, Interpolation interpolation,
                            RasterCounters* counters = nullptr) const {
    RasterOptions options;
    options.tessellationLevel = level;
    options.interpolation = interpolation;
    return positionError(physical, rasterizer.rasterize(physical, textures, options, counters),
                         exact, forwardMap);
  }

  DisplayModel model;
  PhysicalScene physical;
  RayTextures textures;
  VisibilityBuffer traced;
  ExactSurface exact;
  ForwardMap forwardMap;
  Rasterizer rasterizer;
};

// One emissive triangle of `colour`, in physical coordinates (B_W = B_P: the identity map).
Mesh flatTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                  int material) {
  Mesh m;
  m.positions = {a, b, c};
  m.triangles = {{0, 1, 2}};
  m.material = material;
  return m;
}

// The paper's Fig. 6: the tracer's xyz triangle is exact to float precision; the rasterizer's
// is not, and uniform tessellation shrinks its error level after level.
TEST(Rasterizer, XyzTriangleErrorFallsWithTessellationWhileTheTracerIsExact) {
  const ModuleCase c(smallDisplay(3, 200, 150), makeXyzTriangleScene(), 0);
  const PositionError tracer = positionError(c.physical, c.traced, c.exact, c.forwardMap);
  ASSERT_GT(tracer.compared, 1000);
  // mm physical → world units (the xyz colours): B_W = [0, 1]³ is scaled by physicalFromWorld.
  const double worldPerMm = 1e-3 / c.physical.physicalFromWorld().scale;
  EXPECT_LT(tracer.maxMm * worldPerMm, 1e-5);
  EXPECT_LT(tracer.maxPx, 0.01);

  for (Interpolation mode : {Interpolation::kLinear, Interpolation::kPerspective}) {
    double previous = 0.0;
    for (int level = 0; level <= 3; ++level) {
      RasterCounters counters;
      const PositionError e = c.rasterError(level, mode, &counters);
      SCOPED_TRACE(std::string(interpolationName(mode)) + " level " + std::to_string(level));
      EXPECT_GT(e.compared, tracer.compared * 8 / 10);  // level 0: straight edges miss a rim
      EXPECT_EQ(counters.drawnTriangles + counters.droppedTriangles, 1L << (2 * level));
      EXPECT_TRUE(std::isfinite(e.rmsMm) && std::isfinite(e.rmsPx));
      if (level == 0) {
        EXPECT_GT(e.rmsMm, 100.0 * std::max(tracer.rmsMm, 1e-4))
            << "the double perspective must show";
        EXPECT_GT(e.rmsPx, 0.05);
      } else {
        EXPECT_LT(e.rmsMm, 0.8 * previous) << "each level must cut the interpolation error";
      }
      RecordProperty(
          std::string(interpolationName(mode)) + "_level_" + std::to_string(level) + "_rms_mm",
          std::to_string(e.rmsMm));
      previous = e.rmsMm;
    }
  }
}

// Known answer: a triangle lying in the flat screen's plane, seen by the middle module of three
// (facing the screen squarely, no distortion). Its points are their own screen points, so the
// forward map is the module's pinhole projection of a plane parallel to its image: affine.
// Linear interpolation is then exact, and perspective-correct too (w is constant at z = 0):
// a wrong barycentric or a swapped vertex would show as millimetres.
TEST(Rasterizer, AffineCaseMatchesTheTracer) {
  const DisplayModel display = smallDisplay(3, 160, 120);
  Scene scene;
  const int material = scene.addMaterial(Material::makeEmissive(Rgb::Ones()));
  scene.addMesh(flatTriangle({-0.6, -0.3, 0.0}, {0.5, -0.35, 0.0}, {0.1, 0.4, 0.0}, material));
  scene.worldBox = display.displayableBox;
  const ModuleCase c(display, scene, 1);
  ASSERT_NEAR(c.physical.physicalFromWorld().scale, 1.0, 1e-12);
  for (Interpolation mode : {Interpolation::kLinear, Interpolation::kPerspective}) {
    const PositionError e = c.rasterError(0, mode);
    SCOPED_TRACE(interpolationName(mode));
    EXPECT_GT(e.compared, 3000);
    EXPECT_LT(e.rmsMm, 1e-3);
    EXPECT_LT(e.maxMm, 5e-3);
    EXPECT_LT(e.maxPx, 1e-3);
    // Same coverage up to pixel centres lying on an edge to float precision.
    EXPECT_LE(e.candidateOnly + e.exactOnly, 4);
  }
}

// A nearer triangle occludes a farther one whatever the order they are drawn in.
TEST(Rasterizer, ZBufferKeepsTheNearerTriangle) {
  const DisplayModel display = smallDisplay(3, 160, 120);
  for (bool nearFirst : {true, false}) {
    Scene scene;
    const int near = scene.addMaterial(Material::makeEmissive(Rgb(1, 0, 0)));
    const int far = scene.addMaterial(Material::makeEmissive(Rgb(0, 0, 1)));
    const Mesh nearMesh = flatTriangle({-0.5, -0.3, 0.1}, {0.4, -0.3, 0.1}, {0.0, 0.35, 0.1}, near);
    const Mesh farMesh =
        flatTriangle({-0.4, -0.35, -0.1}, {0.5, -0.35, -0.1}, {0.05, 0.3, -0.1}, far);
    scene.addMesh(nearFirst ? nearMesh : farMesh);
    scene.addMesh(nearFirst ? farMesh : nearMesh);
    scene.worldBox = display.displayableBox;
    const ModuleCase c(display, scene, 0);
    const int nearIndex = nearFirst ? 0 : 1;
    const VisibilityBuffer raster = c.rasterizer.rasterize(c.physical, c.textures, RasterOptions{});
    long both = 0, agree = 0;
    for (int row = 0; row < raster.height; ++row) {
      for (int column = 0; column < raster.width; ++column) {
        const SurfaceSample& r = raster.at(column, row);
        const SurfaceSample& t = c.traced.at(column, row);
        if (!r.covered() || !t.covered()) continue;
        if (t.mesh != nearIndex) continue;  // the tracer sees the far one here
        ++both;
        agree += r.mesh == nearIndex;
      }
    }
    EXPECT_GT(both, 1000);
    // Edges of the rasterized near triangle are straight: a few pixels along them may differ.
    EXPECT_GT(static_cast<double>(agree), 0.98 * static_cast<double>(both))
        << "near first: " << nearFirst;
    const Frame frame = shadeDirect(c.physical, raster, c.textures);
    long red = 0;
    for (const Rgb& p : frame.pixels) red += p.x() > 0.5f && p.z() < 0.5f;
    EXPECT_GT(red, both * 9 / 10);
  }
}

TEST(Rasterizer, RejectsAbsurdTessellation) {
  RasterOptions options;
  options.tessellationLevel = 12;
  EXPECT_THROW(options.validate(), InputError);
}

// Anti-aliasing: one sample is the plain render bit for bit; more samples leave a uniformly
// coloured interior alone and blend the edges.
TEST(SupersampledRender, OneSampleIsThePlainFrameAndMoreBlendTheEdges) {
  const DisplayModel display = smallDisplay(3, 120, 90);
  Scene scene;
  const int material = scene.addMaterial(Material::makeEmissive(Rgb(0.5f, 0.5f, 0.5f)));
  scene.addMesh(flatTriangle({-0.6, -0.3, 0.0}, {0.5, -0.35, 0.05}, {0.1, 0.4, -0.05}, material));
  scene.worldBox = display.displayableBox;
  const PhysicalScene physical(scene, display.displayableBox);
  const RayTextures textures = generateRayTextures(display, 1);
  const Frame plain = renderFrame(physical, textures, RenderOptions{});
  RenderOptions options;
  EXPECT_EQ(renderFrame(physical, display, 1, textures, options).pixels, plain.pixels);
  options.samplesPerPixel = 9;
  EXPECT_THROW(renderFrame(physical, textures, options), InputError);
  const Frame smooth = renderFrame(physical, display, 1, textures, options);
  long interior = 0, blended = 0;
  for (size_t i = 0; i < plain.pixels.size(); ++i) {
    const float a = plain.pixels[i].x(), b = smooth.pixels[i].x();
    if (a == 0.5f && b == 0.5f) ++interior;
    if (b > 0.01f && b < 0.49f) ++blended;
    EXPECT_LE(std::abs(a - b), 0.5f + 1e-6f);
  }
  EXPECT_GT(interior, 1000);
  EXPECT_GT(blended, 50) << "edge pixels must be partly covered";
  options.samplesPerPixel = 3;
  EXPECT_THROW(options.validate(), InputError);
}

// A daemon renders every frame into the same buffer: anti-aliased frames too. The frame it is
// given holds the previous frame (here garbage of the right size, then a frame of another
// size); what comes out is the anti-aliased frame, nothing of what was there before.
TEST(SupersampledRender, IntoAReusedFrameIsTheNewFrame) {
  const DisplayModel display = smallDisplay(3, 120, 90);
  Scene scene;
  const int material = scene.addMaterial(Material::makeEmissive(Rgb(0.5f, 0.5f, 0.5f)));
  scene.addMesh(flatTriangle({-0.6, -0.3, 0.0}, {0.5, -0.35, 0.05}, {0.1, 0.4, -0.05}, material));
  scene.worldBox = display.displayableBox;
  const PhysicalScene physical(scene, display.displayableBox);
  const RayTextures textures = generateRayTextures(display, 1);
  RenderOptions options;
  options.samplesPerPixel = 4;
  const Frame expected = renderFrame(physical, display, 1, textures, options);

  Frame reused(textures.width(), textures.height());
  for (Rgb& p : reused.pixels) p = Rgb(7.0f, -3.0f, 0.25f);
  RenderCounters counters;
  renderFrameInto(physical, display, 1, textures, options, &reused, &counters);
  EXPECT_EQ(reused.pixels, expected.pixels);
  EXPECT_EQ(counters.pixels, 4L * textures.width() * textures.height());

  Frame resized(7, 5);
  renderFrameInto(physical, display, 1, textures, options, &resized);
  EXPECT_EQ(resized.width, textures.width());
  EXPECT_EQ(resized.pixels, expected.pixels);

  // One sample through the same entry point: the plain frame.
  options.samplesPerPixel = 1;
  renderFrameInto(physical, display, 1, textures, options, &reused);
  EXPECT_EQ(reused.pixels, renderFrame(physical, textures, options).pixels);
}

}  // namespace
}  // namespace parallax
