#pragma once
// One display frame: every module traced in parallel through its ray textures, then encoded
// to the 8-bit sRGB images the link carries. Nothing is pushed from here: the caller gets
// either the whole set or an exception, so a half-rendered display never reaches the modules.

#include <memory>
#include <vector>

#include "calibration/ray_textures.h"
#include "hw/image.h"
#include "tracer/frame.h"
#include "tracer/physical_scene.h"
#include "tracer/whitted_integrator.h"

namespace parallax::daemon {

struct DisplayFrame {
  std::vector<Frame> frames;                            // linear RGB, for observer views
  std::vector<std::shared_ptr<const hw::Image>> images;  // sRGB 8-bit, what the modules show
  RenderCounters counters;
  double renderMs = 0.0;  // wall clock, all modules
  double encodeMs = 0.0;
};

// The 8-bit image of a frame as a module takes it (RGB8, rows top to bottom).
std::shared_ptr<const hw::Image> encodeForLink(const Frame& frame);

DisplayFrame renderDisplayFrame(const PhysicalScene& scene, const std::vector<RayTextures>& textures,
                                const RenderOptions& options);

}  // namespace parallax::daemon
