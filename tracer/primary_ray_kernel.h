#pragma once
// One row of a tile's primary rays from the ray textures, a SIMD vector of pixels at a time
// (Google Highway, the widest instruction set the CPU has, chosen at run time): each pixel's
// compact ray expanded to o and s − o, the test against the scene's box, and for the rays that
// meet it the unit direction, the origin moved to just before the box and the distance skipped
// (the footprint's start), compress-stored into StagedRays. Every pixel of the row is written:
// black (masked, or traced: the shading adds to it) or the background (the ray misses the box).
// The arithmetic is the scalar formulas' in Eigen's order, without fused multiply-adds, so the
// rays are bit-identical whichever target runs.

#include <Eigen/Core>

#include "calibration/display/ray_textures.h"
#include "tracer/scene.h"
#include "tracer/staged_rays.h"

namespace parallax {

struct PrimaryRayRow {
  const CompactRay* rays = nullptr;  // the row's first pixel in the ray texture
  Rgb* out = nullptr;                // the same pixel in the frame
  int count = 0;                     // pixels in the row
  int firstPixel = 0;                // frame index of the first pixel
  RayFrame frame;
  Eigen::Vector3f boundsMin, boundsMax;  // the scene's box
  float boxMargin = 0.0f;                // rays start this far (metres) before the box
  Rgb background = Rgb::Zero();
};

struct PrimaryRayCounts {
  long masked = 0;        // no ray
  long missedBounds = 0;  // the ray misses the box: background
};

// Appends the row's traced rays to `staged` (reserved for them); kR holds each ray's distance
// skipped, its footprint width so far.
PrimaryRayCounts makePrimaryRays(const PrimaryRayRow& row, StagedRays* staged);

}  // namespace parallax
