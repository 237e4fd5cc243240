#pragma once
// What a frame shows before it is shaded: per pixel, the surface its primary ray (or the
// rasterizer's fragment) landed on, as a triangle of the PhysicalScene and barycentric
// coordinates on it. The tracer and the rasterizer both produce one, so the error toolkit
// (position_error.h) and the direct shading (direct_shading.h) treat them alike.

#include <Eigen/Core>
#include <vector>

#include "calibration/display/ray_textures.h"
#include "tracer/physical_scene.h"

namespace parallax {

struct SurfaceSample {
  int mesh = -1;     // PhysicalScene::meshes() index; −1: nothing (background or masked)
  int triangle = 0;  // index into that mesh's triangles
  float b1 = 0.0f;   // barycentrics of vertices 1 and 2 (vertex 0 has 1 − b1 − b2),
  float b2 = 0.0f;   // Embree's (u, v)

  bool covered() const { return mesh >= 0; }
};

struct VisibilityBuffer {
  int width = 0;
  int height = 0;
  std::vector<SurfaceSample> samples;

  VisibilityBuffer() = default;
  VisibilityBuffer(int w, int h)
      : width(w), height(h), samples(static_cast<size_t>(w) * static_cast<size_t>(h)) {}
  SurfaceSample& at(int column, int row) {
    return samples[static_cast<size_t>(row) * static_cast<size_t>(width) +
                   static_cast<size_t>(column)];
  }
  const SurfaceSample& at(int column, int row) const {
    return samples[static_cast<size_t>(row) * static_cast<size_t>(width) +
                   static_cast<size_t>(column)];
  }
  long coveredCount() const;
};

// The physical position of a sample (float, from the triangle's vertices).
Eigen::Vector3f surfacePosition(const PhysicalScene& scene, const SurfaceSample& sample);

// The ray tracer's answer: every unmasked pixel's primary ray traced through the BVH (the first
// generation of renderFrame, without shading). Parallel over rows.
VisibilityBuffer tracePrimaryVisibility(const PhysicalScene& scene, const RayTextures& textures);

}  // namespace parallax
