#pragma once
// The Whitted integrator over one module's ray textures (the paper's Section 4): for every
// unmasked pixel the primary ray from o through s, then at every hit a shadow ray per light for
// diffuse surfaces, a reflection ray for mirrors, and Fresnel-weighted reflection and
// refraction rays for glass, to the depth the scene needs (scene_features.h).
//
// It runs wavefront-style per tile: the rays of one generation of a tile are gathered into an
// array and traced together (ray_batch.h), shadow rays likewise, so Embree can use packets or
// streams; tiles run in parallel under TBB. Every ray it traces is counted.

#include <functional>
#include <string>
#include <vector>

#include "calibration/display/ray_textures.h"
#include "tracer/frame.h"
#include "tracer/physical_scene.h"
#include "tracer/ray_batch.h"
#include "tracer/scene_footprint.h"
#include "tracer/static_visibility.h"

namespace parallax {

struct RayLog;  // ray_log.h: the bench records a frame's rays

struct RenderOptions {
  Traversal traversal =
      Traversal::kStream;  // chosen by `parallax bench tracer` (fastest, CPU time)
  int tileWidth = 32;
  int tileHeight = 16;
  // A branch whose weight falls below this on every channel is not traced: its contribution
  // cannot change an 8-bit pixel by more than half a step. 0 traces every branch.
  float minWeight = 1.0f / 512.0f;
  int maxDepth = 0;              // 0: the scene's own (always capped at what its materials need)
  bool textureFiltering = true;  // false: bilinear on the full-resolution level only
  // Anti-aliasing: n × n sub-pixel rays a pixel (a square: 1, 4, 9, ...). Sub-pixel rays come
  // from the ray function, so anything above 1 needs the display model: renderFrameInto of
  // supersampled_render.h. 1 is the plain ray textures, unchanged.
  int samplesPerPixel = 1;
  // Time each phase of the render (RenderCounters::phaseThreadMs): a clock read at every phase
  // change of every tile, about 2% of a frame, so only the bench asks for it.
  bool timePhases = false;
  // false: every hit through the scalar shading, and every shadow ray's light added one by one
  // (the reference the SIMD shading kernels' test compares with, bit for bit).
  bool packetShading = true;
  // Shadow rays that pass every mesh's bounding sphere (and a flat mesh's plane; their own
  // mesh's skipped where they leave a bare face of it) add their light without a trip through
  // Embree (PhysicalScene::occluders). false:
  // every ray is traced (the reference the test compares with, bit for bit).
  bool boundShadowRays = true;
  // A mirror's or glass's reflection or refraction ray that leaves a bare face of its mesh is
  // traced against the scene without that mesh (PhysicalScene::withoutMesh), which it cannot
  // meet. false: against the whole scene (the reference the test compares with, bit for bit).
  bool skipMeshLeft = true;

  // Throws InputError naming the option.
  void validate() const;
};

// Where a frame's CPU time goes (RenderOptions::timePhases).
enum class RenderPhase : int {
  kGenerate,   // primary rays from the ray textures, box test
  kIntersect,  // Embree: primary and secondary rays
  kShade,      // hit records, materials, branches, shadow rays made
  kOcclude,    // Embree: shadow rays (the glass filter included)
  kGather,     // unoccluded shadow rays added to their pixels
};
inline constexpr int kRenderPhases = 5;
const char* renderPhaseName(RenderPhase phase);

struct RenderCounters {
  long pixels = 0;
  long masked = 0;        // no ray: never traced
  long missedBounds = 0;  // ray misses the scene's bounding box: background, never traversed
  long primary = 0;
  long shadow = 0;
  long reflection = 0;
  long refraction = 0;
  long pruned = 0;  // branches below RenderOptions::minWeight
  // Glass surfaces shadow rays met and passed through (calls of the glass filter, per ray and
  // surface, duplicates from the BVH's spatial splits included): not extra rays.
  long glassShadowHits = 0;
  // Shadow rays not traced: they pass every mesh's bound (boundShadowRays).
  long shadowPassedBounds = 0;
  // Shadow rays not traced: they go through a closed convex mesh's core (OccluderBound::core).
  long shadowBlockedByCores = 0;
  // Reflection and refraction rays traced against the scene without the mesh they leave
  // (RenderOptions::skipMeshLeft).
  long withoutMeshLeft = 0;
  // Pixels outside the scene's footprint (scene_footprint.h): counted among masked and
  // missedBounds too, yet not even read.
  long outsideFootprint = 0;
  long textureLookups = 0;
  FrameCacheCounters cache;  // what the frame cache saved (zero without one)
  int deepest = 0;           // highest ray generation traced (1 = primary only)
  // Wall-clock time each thread spent in each phase, summed over the threads (timePhases):
  // close to CPU time while the threads are not preempted.
  double phaseThreadMs[kRenderPhases] = {};

  RenderCounters& operator+=(const RenderCounters& o);
  long rays() const { return primary + shadow + reflection + refraction; }
  std::vector<std::string> lines() const;
};

// Renders one module frame into `frame`, reusing its memory when it already has the textures'
// size (a daemon renders every frame into the same buffers). `textures` must come from the
// display the scene was mapped into. samplesPerPixel > 1 throws InputError: sub-pixel rays need
// the display model (renderFrameInto of supersampled_render.h). `log` (the bench's, ray_log.h)
// receives every batch traced.
void renderFrameInto(const PhysicalScene& scene, const RayTextures& textures,
                     const RenderOptions& options, Frame* frame, RenderCounters* counters = nullptr,
                     RayLog* log = nullptr);
// Through the frame cache's view of this module (frame_cache.h; `scene` split into static and
// dynamic instances): with `cache.build` it fills the view's records from the static BVH (the
// primary rays and their shadow rays toward the static lights; `frame` then holds nothing
// useful), else it renders the frame as the plain renderFrameInto would, tracing the first
// generation against the dynamic instances only and taking the rest from the records.
void renderFrameInto(const PhysicalScene& scene, const RayTextures& textures,
                     const RenderOptions& options, const StaticVisibilityView& cache, Frame* frame,
                     RenderCounters* counters = nullptr);
// Called with each tile's columns [x0, x1) and rows [y0, y1) once its pixels are final, on the
// thread that rendered it (tiles run in parallel): what it does with them is still in cache.
using TileDone = std::function<void(int x0, int x1, int y0, int y1)>;
// Only the pixels inside `footprint` (scene_footprint.h; it must hold the scene's bounds) are
// read and written, the same as a full frame writes them; the others keep what `frame` held.
// `cache`: the frame cache's view as above, or null. `tileDone`: null, or called per tile.
void renderFrameInto(const PhysicalScene& scene, const RayTextures& textures,
                     const RenderOptions& options, const SceneFootprint& footprint,
                     const StaticVisibilityView* cache, Frame* frame,
                     RenderCounters* counters = nullptr, const TileDone* tileDone = nullptr);
// The same into a new frame.
Frame renderFrame(const PhysicalScene& scene, const RayTextures& textures,
                  const RenderOptions& options, RenderCounters* counters = nullptr,
                  RayLog* log = nullptr);

}  // namespace parallax
