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
// Whether it pays is measured, not assumed: where the moving objects or the moving lights are
// most of a frame's work (orbit.lua: a turning key light re-shades every pixel), the cache
// saves next to nothing and holds 12 bytes a pixel (648 MiB on `default`). When the caller
// reports each frame's CPU time (reportFrameCost), the frames after a build alternate between
// the cache and a full re-trace (the same images either way) until kTrialFrames of each are
// timed; if the re-traces cost less than kMinGain times the cached frames, the records are
// freed and frames are rendered in full until the cache's basis (static geometry, dynamic
// objects, ray textures) changes. The decision and its figures are in stats().payoff.
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
  // Whether it pays (reportFrameCost): empty until the trial after a build ends.
  std::string payoff;
  long framesMeasured = 0;     // trial frames rendered without the cache (of framesBypassed)
  std::size_t bytesFreed = 0;  // records dropped because they did not pay (all trials)
  bool declined = false;       // the records did not pay: frames are rendered in full

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
  // The CPU time (ms) of the frame just prepared, through the cache or not: the trial's samples.
  // A caller that never reports renders every frame through the cache (the tests' way).
  void reportFrameCost(double cpuMs);

  // The trial: this many frames each way after a build; the records stay when the re-traces
  // cost at least kMinGain times the cached frames (medians).
  static constexpr int kTrialFrames = 3;
  static constexpr double kMinGain = 1.1;

  const FrameCacheStats& stats() const { return stats_; }
  // Drops the records (memory freed) and what the trial learnt; the next frame builds again.
  void clear();

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

  void dropRecords();

  // The payoff trial (reportFrameCost): what the frame just prepared was.
  enum FrameKind { kUntimed, kCached, kTrialFull };  // kUntimed: a build's or a bypassed frame
  FrameKind frameKind_ = kUntimed;
  bool trial_ = false;
  std::vector<double> cachedCost_, fullCost_;
  void judge();
  // The basis of the records that did not pay (stats_.declined): a change of any builds again.
  std::vector<bool> declinedDynamic_;
  std::uint64_t declinedHash_ = 0;
  std::uint64_t declinedTexturesVersion_ = 0;
  FrameCacheStats stats_;
};

}  // namespace parallax
