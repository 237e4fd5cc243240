#pragma once
// Anti-aliasing for the ray tracer: RenderOptions::samplesPerPixel = n² sub-pixel rays a pixel,
// at the centres of an n × n grid of strata, ((a + ½)/n, (b + ½)/n) inside the pixel, taken
// from the ray function of DESIGN.md (RayFunction::at is a function of continuous (u, v)).
// Stratum centres rather than jittered positions: frames stay deterministic, and the display's
// rays are smooth, so jitter would only add noise. Each grid is generated in the ray tracer's
// compact form and traced as a frame of its own; the frames are averaged.
// A pixel masked at its centre stays black (as at 1 sample); a sub-sample whose own ray is
// masked (a pixel straddling the edge of the image's valid part) is left out of its average.

#include "calibration/display/display_model.h"
#include "calibration/display/ray_textures.h"
#include "tracer/frame.h"
#include "tracer/whitted_integrator.h"

namespace parallax {

struct SupersampleTimes {
  double rayGenerationMs = 0.0;  // sub-pixel ray textures (constants a daemon would cache)
  double traceMs = 0.0;          // tracing and shading them
};

// Renders one module frame at options.samplesPerPixel into `frame`, reusing its memory when it
// already has the size of `centres`, the module's ray textures (a daemon renders every frame
// into the same buffers). 1 sample is exactly whitted_integrator.h's renderFrameInto(scene,
// centres, ...); above, each call generates the sub-pixel ray textures from `model` again
// (SupersampleTimes::rayGenerationMs).
void renderFrameInto(const PhysicalScene& scene, const DisplayModel& model, int moduleIndex,
                     const RayTextures& centres, const RenderOptions& options, Frame* frame,
                     RenderCounters* counters = nullptr, SupersampleTimes* times = nullptr);
// The same into a new frame.
Frame renderFrame(const PhysicalScene& scene, const DisplayModel& model, int moduleIndex,
                  const RayTextures& centres, const RenderOptions& options,
                  RenderCounters* counters = nullptr, SupersampleTimes* times = nullptr);

// The compact ray textures of the sub-pixel position (column + du, row + dv) of every pixel.
RayTextures generateOffsetRayTextures(const DisplayModel& model, int moduleIndex, double du,
                                      double dv);

}  // namespace parallax
