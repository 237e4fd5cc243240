#pragma once
// The conventional baseline the paper compares ray tracing against: per module, every triangle's
// vertices are projected with the forward map (calibration/display/forward_map.h, the "double
// perspective"), the projected triangles are scan-converted at pixel centres with a z-buffer,
// and attributes are interpolated across them. The forward map is not projective, so the
// straight edges and the interpolation in the module image are only approximations of where the
// pixels' rays meet the triangle; uniform tessellation (each triangle split into 4^n before
// projection) shrinks that error at the price of projecting more vertices.
//
// Choices, stated once:
// - Output: a VisibilityBuffer (triangle + barycentrics per pixel, as the tracer's primary rays
//   give), so shading and the error toolkit treat both alike and the frames compare pixel for
//   pixel. Interpolating the source triangle's barycentrics is the same as interpolating every
//   vertex attribute, since attributes are linear in them.
// - Depth: physical z, nearer = larger z (toward the viewers). Every primary ray runs from the
//   observer line toward −z, so along one pixel's ray z orders points exactly as the distance
//   from o does, and it is a plain vertex attribute that needs no per-pixel ray.
// - Perspective-correct: the vertical half of the double perspective is an exact central
//   projection from the observer line (o.y, o.z are the same for every pixel), whose depth is
//   w = z_obs − z; interpolating attribute/w and 1/w is exact for it alone. The horizontal half
//   is a perspective from the module, whose depth (z − p.z) grows toward the viewers where
//   z_obs − z shrinks: no single 1/w corrects both, and measured on the xyz triangle (tests,
//   `parallax report`) this variant is *worse* than linear interpolation (as is the module's
//   own depth as w), plausibly because the two halves' errors partly cancel when neither is
//   corrected.
// - Vertices are projected with the forward map continued past the screen's edges
//   (ForwardMap::pixelOfContinued): a vertex seen beyond the screen gets a pixel off the image
//   and the scan conversion clips in the image. Vertices whose map still fails (no ray, even
//   continued, passes through them): every small triangle using one is dropped and counted; a
//   triangle is never clipped in 3-D.
// - Culling: a triangle whose three projected corners, with a margin of half their bounding box
//   (the map bends edges by far less), lie off one side of the image is dropped before
//   tessellation. No back-face culling: shading is two-sided, as in the tracer.
// - Masked pixels stay uncovered (black), as in the tracer.

#include <string>

#include "calibration/display/display_model.h"
#include "calibration/display/forward_map.h"
#include "calibration/display/ray_textures.h"
#include "tracer/frame.h"
#include "tracer/physical_scene.h"
#include "tracer/visibility_buffer.h"

namespace parallax {

enum class Interpolation { kLinear, kPerspective };
const char* interpolationName(Interpolation interpolation);

struct RasterOptions {
  int tessellationLevel = 0;  // each triangle split into 4^level before projection
  Interpolation interpolation = Interpolation::kLinear;
  int bandRows = 16;  // rows per parallel band

  // Throws InputError naming the option.
  void validate() const;
};

struct RasterCounters {
  long sourceTriangles = 0;
  long culledTriangles = 0;    // source triangles wholly off the image (before tessellation)
  long projectedVertices = 0;  // forward-map evaluations
  long failedVertices = 0;     // no pixel's ray passes through them
  long droppedTriangles = 0;   // small triangles with a failed vertex
  long drawnTriangles = 0;     // small triangles scan-converted
  long fragments = 0;          // pixel centres inside a drawn triangle (depth tests)
  long coveredPixels = 0;
  double projectMs = 0.0, rasterMs = 0.0;
};

class Rasterizer {
 public:
  Rasterizer(const DisplayModel& model, int moduleIndex);

  // `textures` (of the same module) supplies the resolution and the mask.
  VisibilityBuffer rasterize(const PhysicalScene& scene, const RayTextures& textures,
                             const RasterOptions& options,
                             RasterCounters* counters = nullptr) const;

 private:
  const DisplayModel& model_;
  ForwardMap forwardMap_;
};

// rasterize + the shading a rasterizer can do (direct_shading.h).
Frame rasterizeFrame(const Rasterizer& rasterizer, const PhysicalScene& scene,
                     const RayTextures& textures, const RasterOptions& options,
                     RasterCounters* counters = nullptr);

}  // namespace parallax
