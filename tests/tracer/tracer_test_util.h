#pragma once
// Shared helpers of the tracer tests: a small display, pixel rays in double precision and in
// world space, and position-coloured emissive planes whose colour at a point encodes the point
// (so a pixel's colour tells where its ray path ended).

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <optional>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
#include "tracer/physical_scene.h"
#include "tracer/scene.h"
#include "tracer/whitted_integrator.h"

namespace parallax::test {

// The demo screen with `modules` modules of width × height (fast enough for unit tests).
inline DisplayModel smallDisplay(int modules = 3, int width = 160, int height = 120) {
  NominalDisplayOptions options;
  options.preset = "demo";
  options.modules = modules;
  options.width = width;
  options.height = height;
  return makeNominalDisplay(options);
}

struct WorldRay {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;  // unit
};

// The pixel's primary ray mapped into world space (uniform scale: directions unchanged).
inline std::optional<WorldRay> worldRayOf(const RayTextures& textures, int column, int row,
                                          const WorldToPhysical& physicalFromWorld) {
  const CompactRay& r = textures.at(column, row);
  if (r.masked()) return std::nullopt;
  const Eigen::Vector3d o = textures.frame().origin(r).cast<double>();
  const Eigen::Vector3d s = textures.frame().screenPoint(r).cast<double>();
  return WorldRay{physicalFromWorld.worldPoint(o), (s - o).normalized()};
}

// Distance along the ray to the plane n·x = c (nullopt when parallel or behind).
inline std::optional<double> hitPlane(const WorldRay& ray, const Eigen::Vector3d& n, double c) {
  const double denom = n.dot(ray.direction);
  if (std::abs(denom) < 1e-12) return std::nullopt;
  const double t = (c - n.dot(ray.origin)) / denom;
  if (!(t > 0.0)) return std::nullopt;
  return t;
}

// A traced pixel: its module, place, rendered colour and primary ray in world space.
struct RenderedPixel {
  int module, column, row;
  Rgb colour;
  WorldRay ray;
};

// Renders modules 0 .. modules − 1 and hands every pixel that has a primary ray to `visit`:
// the loop of every test that checks pixels against an analytic path. Counters are summed
// over the modules when asked for.
template <class Visit>
void forEachRenderedPixel(const DisplayModel& display, int modules, const PhysicalScene& scene,
                          const RenderOptions& options, Visit&& visit,
                          RenderCounters* counters = nullptr) {
  for (int module = 0; module < modules; ++module) {
    const RayTextures textures = generateRayTextures(display, module);
    RenderCounters moduleCounters;
    const Frame frame = renderFrame(scene, textures, options, &moduleCounters);
    if (counters) *counters += moduleCounters;
    for (int row = 0; row < textures.height(); ++row) {
      for (int column = 0; column < textures.width(); ++column) {
        const auto ray = worldRayOf(textures, column, row, scene.physicalFromWorld());
        if (ray) visit(RenderedPixel{module, column, row, frame.at(column, row), *ray});
      }
    }
  }
}

// An emissive rectangle with vertex colours = (a + offset, b + offset, 1) where (a, b) are the
// two in-plane world coordinates `axisA`, `axisB` of the point: linear, so the interpolated
// colour at any point encodes that point exactly, and dividing by the third channel cancels
// any weight (Fresnel, reflectance) the path picked up.
inline Mesh positionColouredRect(int axisA, int axisB, int normalAxis, double planeCoord,
                                 double halfSize, double offset, int material) {
  Mesh m;
  m.material = material;
  const double corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  for (const auto& c : corners) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    p[axisA] = c[0] * halfSize;
    p[axisB] = c[1] * halfSize;
    p[normalAxis] = planeCoord;
    m.positions.push_back(p);
    m.colors.push_back(
        Rgb(static_cast<float>(p[axisA] + offset), static_cast<float>(p[axisB] + offset), 1.0f));
  }
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

// A pixel whose path ended on a positionColouredRect (offset 2) at in-plane coordinates (a, b):
// its colour, with the path's weight divided out, must say so.
inline void expectPaintedAt(const RenderedPixel& p, double a, double b, double tolerance) {
  EXPECT_NEAR(p.colour.x() / p.colour.z(), a + 2.0, tolerance) << p.column << "," << p.row;
  EXPECT_NEAR(p.colour.y() / p.colour.z(), b + 2.0, tolerance) << p.column << "," << p.row;
}

}  // namespace parallax::test
