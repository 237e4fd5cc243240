#pragma once
// The frame cache (issue 22): an animated scene re-traces, frame after frame, the same
// primary hits on the geometry that does not move (floor, walls, pedestal) and the same
// shadow rays from those hits to the lights that do not move. The cache traces them once per
// scene and display (static_visibility.h: 12 bytes a pixel) and every frame traces the
// primary rays, and the shadow rays of the static hits toward the static lights, against the
// moving instances only; everything else (secondary rays, moved lights, the shading) as
// before, so a frame is the one a full re-trace gives.
//
// What is static is learned, not trusted: an instance is dynamic when the script moved it
// (Scene::movedInstances, the set_transform targets) or when its transform differs from the
// previous frame's. The records stay valid while the static meshes in physical space (a hash
// of their positions, triangles and normals: a reload, a world box or a clipping change alters
// it), the ray textures and the set of dynamic instances stay as they were at the build; a
// static light that moves is traced again like any other. When a frame finds the cache stale it
// is built again for that frame; when that happens frame after frame (a scene whose world box
// follows its moving objects), frames are rendered without the cache and the rebuilds back off.
//
// Use, once a frame, on the render thread:
//   const auto& dynamic = cache.dynamicInstances(scene);
//   PhysicalScene physical(scene, box, &dynamic);
//   if (cache.prepare(physical, textures, texturesVersion, options))
//     ... renderFrameInto(physical, textures[i], options, cache.view(i), ...)

#include <cstdint>
#include <string>
#include <vector>

#include "calibration/display/ray_textures.h"
#include "tracer/physical_scene.h"
#include "tracer/scene.h"
#include "tracer/static_visibility.h"
#include "tracer/whitted_integrator.h"

namespace parallax {

struct FrameCacheStats {
  long builds = 0;
  double lastBuildMs = 0.0;  // wall clock of the last build, all modules
  double buildMs = 0.0;      // all builds
  long framesCached = 0;     // frames rendered through the cache
  long framesBypassed = 0;   // frames rendered without it (stale and backing off, or useless)
  long pixels = 0;           // pixels the records cover
  std::size_t bytes = 0;     // the records' memory
  int staticInstances = 0, dynamicInstances = 0;
  int cachedLights = 0;      // static lights whose shadows the records hold (last frame)
  std::string lastRebuild;   // why the cache was last built or bypassed
  FrameCacheCounters saved;  // over all frames rendered through it

  double bytesPerPixel() const {
    return pixels > 0 ? static_cast<double>(bytes) / static_cast<double>(pixels) : 0.0;
  }
  std::vector<std::string> lines() const;
};

class FrameCache {
 public:
  // Per instance of `scene`: whether this frame traces it as dynamic. First call of a frame.
  const std::vector<bool>& dynamicInstances(const Scene& scene);
  // Checks the records against this frame's scene (built with dynamicInstances()) and
  // textures; builds them when stale. True: render each module through view(i) this frame.
  bool prepare(PhysicalScene& scene, const std::vector<RayTextures>& textures,
               std::uint64_t texturesVersion, const RenderOptions& options);
  // Module i's records as this frame's scene names them (after prepare returned true).
  StaticVisibilityView view(std::size_t module);
  // The frame's counters: what the cache saved (adds to stats().saved).
  void count(const RenderCounters& frame) { stats_.saved += frame.cache; }

  const FrameCacheStats& stats() const { return stats_; }
  void clear();  // drops the records (memory freed); the next frame builds them again

 private:
  void build(PhysicalScene& scene, const std::vector<RayTextures>& textures,
             const RenderOptions& options);
  std::uint64_t staticHash(const PhysicalScene& scene) const;
  void mapStaticMeshes(const PhysicalScene& scene);

  // The scene's layout and the previous frame's transforms (what "moved" compares against).
  std::vector<int> instanceMesh_;
  std::vector<Eigen::Matrix<double, 3, 4>> lastTransforms_;
  std::vector<bool> dynamic_;
  bool dynamicChanged_ = false;  // an instance joined the dynamic ones this frame

  // What the records were built for.
  bool built_ = false;
  std::vector<bool> builtDynamic_;
  std::uint64_t builtHash_ = 0;
  std::uint64_t builtTexturesVersion_ = 0;
  std::vector<PhysicalLight> builtLights_;
  std::vector<std::vector<StaticHit>> records_;  // per module

  // Static meshes in instance order, and this frame's view of them.
  std::vector<int> staticInstances_;
  std::vector<std::uint32_t> triangleBase_;  // per static instance, plus the total
  std::vector<int> meshOfStatic_;            // this frame: static ordinal -> mesh index
  std::vector<int> staticOfMesh_;            // this frame: mesh index -> static ordinal or -1
  std::uint8_t lightsValid_ = 0;

  int staleFrames_ = 0;  // consecutive frames that found the records stale
  long frame_ = 0, nextBuildFrame_ = 0;
  FrameCacheStats stats_;
};

}  // namespace parallax
