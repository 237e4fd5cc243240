#pragma once
// The shading a rasterizer can do without secondary rays: at every covered pixel, emission,
// ambient, and diffuse (+ Phong) lighting from every light with no shadow test; texture
// colour bilinear on the full-resolution level (no ray footprint). Mirrors and glass need
// rays the rasterizer does not have (it cannot do Whitted): they show only their emission and
// are counted. Same Frame layout as renderFrame, so the two compare pixel for pixel.

#include "calibration/display/ray_textures.h"
#include "tracer/frame.h"
#include "tracer/physical_scene.h"
#include "tracer/visibility_buffer.h"

namespace parallax {

struct DirectShadingCounters {
  long shaded = 0;
  long unshadeable = 0;  // mirror or glass pixels: need secondary rays
};

// `textures` gives each pixel's view direction (for the facing and the highlight).
Frame shadeDirect(const PhysicalScene& scene, const VisibilityBuffer& visibility,
                  const RayTextures& textures, DirectShadingCounters* counters = nullptr);

}  // namespace parallax
