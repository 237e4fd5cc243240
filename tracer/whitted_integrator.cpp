#include "tracer/whitted_integrator.h"

#include <fmt/format.h>
#include <tbb/blocked_range2d.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "common/check.h"
#include "common/input_error.h"
#include "tracer/diffuse_hit_kernel.h"
#include "tracer/glass_shadows.h"
#include "tracer/hit_info.h"
#include "tracer/optics.h"
#include "tracer/primary_ray_kernel.h"
#include "tracer/ray_log.h"
#include "tracer/ray_packets.h"
#include "tracer/shadow_ray_kernel.h"
#include "tracer/static_hit_kernel.h"
#include "tracer/texture_lookup_kernel.h"

namespace parallax {
namespace {

// Path::coneSpread of a primary ray whose footprint has not been computed yet.
constexpr float kConeUnknown = -1.0f;

// One branch of a pixel's Whitted tree, waiting for its ray to be traced.
// Every field is written where a path is made (initialRays, pushBranch): no initialisers, so
// that growing a tile's array of them (PathVector) writes nothing it will write again.
struct Path {
  int pixel;
  Rgb weight;
  float coneWidth;   // footprint width at the ray origin (physical metres)
  float coneSpread;  // growth of that width per metre travelled
  int inside;        // material index of the glass the ray travels in, -1 in air
};

// A vector whose resize() leaves the new elements default-initialised (for Path: untouched).
// Value-initialising them was a tenth of the tile loop's time on `default`, all of it
// overwritten at once.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
using PathVector = std::vector<Path, DefaultInitAllocator<Path>>;

// Adds the time since the previous lap to the phase that just ended (when timing is on).
class PhaseClock {
 public:
  PhaseClock(bool on, RenderCounters* counters) : on_(on), counters_(counters) {
    if (on_) last_ = std::chrono::steady_clock::now();
  }
  void lap(RenderPhase ended) {
    if (!on_) return;
    const auto now = std::chrono::steady_clock::now();
    counters_->phaseThreadMs[static_cast<int>(ended)] +=
        std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
  }

 private:
  bool on_;
  RenderCounters* counters_;
  std::chrono::steady_clock::time_point last_;
};

// One light's shadow rays toward one scene: as the kernel made them (with what each adds to
// its pixel), then as Embree's packets.
struct ShadowBatch {
  StagedRays staged;
  OcclusionPackets rays;
  // Per shadow ray: what glass let through, and whether the glass filter met it (only in scenes
  // with glass shadows; a state is reset when the filter first meets its ray).
  std::vector<ShadowTransmittance> transmittance;
  std::vector<std::uint8_t> seen;
  size_t parked = 0;  // rays that pass every bound, kept in place but not traced

  // The staged rays as packets, none of them met by the glass filter yet.
  void load(bool glass) {
    rays.assign(staged);
    if (!glass) return;
    if (transmittance.size() < staged.size()) transmittance.resize(staged.size());
    seen.assign(staged.size(), 0);
  }
  bool crossedGlass(size_t i) const {
    return parallax::crossedGlass(transmittance.data(), seen.data(), i);
  }
};

// A worker thread's ray arrays, kept from frame to frame (thread_local below): after the first
// frame a tile allocates nothing.
struct TileBuffers {
  PathVector paths, nextPaths;
  RayHitPackets rays, nextRays;
  // Per ray of a later generation, the scene it is traced against: the whole one, or one
  // without the mesh it leaves (PhysicalScene::withoutMesh). Kept only when the scene has those.
  std::vector<RTCScene> scenes, nextScenes;
  LitSurfaces lit;
  // Shadow rays are made and traced light after light: a packet then holds neighbouring
  // pixels' rays toward the same light, which traverse the BVH together. With the frame cache,
  // rays from static hits toward static lights that no static surface blocks go to a second
  // batch, traced against the dynamic instances only.
  ShadowBatch shadows, dynamicShadows;
  // And the rays of that batch that pass every dynamic object's bounds: not traced.
  StagedRays unblocked;
  // The frame cache, per primary ray: its static hit, and that hit's static-light answers.
  CachedHits cachedHits;
  std::vector<std::uint8_t> primaryLights;
  StagedRays primary;  // the first generation as the kernel made it
};

class TileRenderer {
 public:
  TileRenderer(const PhysicalScene& scene, const RayTextures& textures,
               const RenderOptions& options, int depth, Frame* frame, RayLog* log,
               TileBuffers* buffers, const StaticVisibilityView* cache,
               const SceneFootprint* footprint)
      : scene_(scene),
        textures_(textures),
        options_(options),
        depth_(depth),
        frame_(frame),
        log_(log),
        texturesUsed_(scene.features().texturePass()),
        boxMargin_(0.01f * (scene.boundsMax() - scene.boundsMin()).norm()),
        glassShadows_(scene.glassShadows()),
        skipMeshLeft_(options.skipMeshLeft && scene.hasWithoutMeshScenes()),
        paths_(buffers->paths),
        nextPaths_(buffers->nextPaths),
        rays_(buffers->rays),
        nextRays_(buffers->nextRays),
        scenes_(buffers->scenes),
        nextScenes_(buffers->nextScenes),
        lit_(buffers->lit),
        shadows_(buffers->shadows),
        dynamicShadows_(buffers->dynamicShadows),
        unblocked_(buffers->unblocked),
        cachedHits_(buffers->cachedHits),
        primaryLights_(buffers->primaryLights),
        primaryStaged_(buffers->primary),
        cache_(cache),
        footprint_(footprint) {}

  void render(int x0, int x1, int y0, int y1, RenderCounters* c);

 private:
  void initialRays(int x0, int x1, int y0, int y1, RenderCounters* c);
  void cone(int pixel, Path* path) const;
  void shade(size_t i, int generation, RenderCounters* c);
  bool shadeDiffusePacket(size_t packet, RenderCounters* c);
  bool shadeOneMeshPacket(size_t packet, RenderCounters* c);
  void textureDiffusePacket(size_t packet, unsigned geomID, const PhysicalMesh& mesh,
                            const Material& m, size_t first, RenderCounters* c);
  void makeShadowRays(const PhysicalLight& light, int lightIndex, int generation,
                      const SurfaceSpread& spread, RenderCounters* c);
  void traceShadowRays(ShadowBatch& batch, RTCScene scene, bool coherent, int generation,
                       RenderCounters* c, PhaseClock* clock);
  void recordStaticShadows(const ShadowBatch& batch, int lightIndex);
  // The frame cache around the first generation's intersection.
  RTCScene primaryScene() const;
  StaticHitJob staticHitJob();
  void limitToStaticHits();
  std::uint8_t cachedStaticLights(size_t ray, int pixel);
  void takeStaticHits(RenderCounters* c);
  void recordStaticHits();
  Rgb textureColor(const Material& m, const HitInfo& h, const Path& path, float t,
                   const Eigen::Vector3f& d, RenderCounters* c) const;
  void pushBranch(const Path& parent, const Rgb& weight, const Eigen::Vector3f& origin,
                  const Eigen::Vector3f& dir, int inside, float coneWidth, int meshLeft,
                  RenderCounters* c);
  int meshLeft(unsigned geomID, unsigned prim, bool frontSide, const Eigen::Vector3f& side,
               const Eigen::Vector3f& dir) const;
  void logBatch(int generation, const RayHitPackets& rays);
  void logBatch(int generation, const OcclusionPackets& rays);
  void logBatch(bool occlusion, int generation, std::vector<RTCRay> rays);

  const PhysicalScene& scene_;
  const RayTextures& textures_;
  const RenderOptions& options_;
  const int depth_;
  Frame* frame_;
  RayLog* log_;
  const bool texturesUsed_;  // the scene samples a texture (ray footprints are needed)
  const float boxMargin_;    // primary rays start this far (metres) before the scene's box
  const bool glassShadows_;  // shadow rays pass through glass (glass_shadows.h)
  // Reflection and refraction rays that leave a bare face of their mesh are traced without it
  // (RenderOptions::skipMeshLeft, and the scene has such meshes).
  const bool skipMeshLeft_;

  PathVector& paths_;
  PathVector& nextPaths_;
  RayHitPackets& rays_;
  RayHitPackets& nextRays_;
  std::vector<RTCScene>& scenes_;
  std::vector<RTCScene>& nextScenes_;
  LitSurfaces& lit_;  // this generation's diffuse hits
  ShadowBatch& shadows_;
  ShadowBatch& dynamicShadows_;
  StagedRays& unblocked_;
  CachedHits& cachedHits_;
  std::vector<std::uint8_t>& primaryLights_;
  StagedRays& primaryStaged_;
  // The frame cache: null without one; build mode fills it from the static scene, else the
  // first generation reads it and traces against the dynamic instances only.
  const StaticVisibilityView* cache_;
  // Only the pixels inside it are written (null: every pixel).
  const SceneFootprint* footprint_;
};

// o and s − o of a compact ray. A flat screen (the common case) needs no sag and its square root.
inline void expand(const RayFrame& f, const CompactRay& r, Eigen::Vector3f* o,
                   Eigen::Vector3f* toScreen) {
  const float sz = f.curvature == 0.0f ? 0.0f : screenSag(f.curvature, r.screenX);
  *o = {r.originX, f.observerY, f.observerZ};
  *toScreen = {r.screenX - r.originX, r.screenY - f.observerY, sz - f.observerZ};
}

void TileRenderer::cone(int pixel, Path* path) const {
  // Footprint from the neighbouring pixels' rays (a ray differential): the width is the offset
  // between neighbouring origins, the spread the angle between neighbouring directions (small
  // angles: the change of s − o over its length).
  const RayFrame& f = textures_.frame();
  const int column = pixel % textures_.width(), row = pixel / textures_.width();
  const CompactRay& self = textures_.at(column, row);
  Eigen::Vector3f origin, toScreen;
  expand(f, self, &origin, &toScreen);
  const float inverseLength = 1.0f / toScreen.norm();
  float width = 0.0f, spread = 0.0f;
  const int nx = column + 1 < textures_.width() ? column + 1 : column - 1;
  const int ny = row + 1 < textures_.height() ? row + 1 : row - 1;
  for (const CompactRay* n : {nx >= 0 ? &textures_.at(nx, row) : nullptr,
                              ny >= 0 ? &textures_.at(column, ny) : nullptr}) {
    if (!n || n->masked()) continue;
    Eigen::Vector3f o, t;
    expand(f, *n, &o, &t);
    width = std::max(width, std::abs(n->originX - self.originX));
    spread = std::max(spread, (t - toScreen).norm() * inverseLength);
  }
  path->coneWidth =
      width + path->coneWidth * spread;  // coneWidth: the distance the origin was advanced
  path->coneSpread = spread;
}

void TileRenderer::initialRays(int x0, int x1, int y0, int y1, RenderCounters* c) {
  const size_t capacity = static_cast<size_t>(x1 - x0) * static_cast<size_t>(y1 - y0);
  // A tile's rows are short runs far apart in the ray texture and the frame (12 B a pixel, a
  // row of 1024 pixels 12 KB): too short for the hardware prefetcher, so every row started
  // with cache misses (a quarter of this loop's time in the profile). Ask for all of them first.
  // Only the columns where a row has unmasked pixels are read (RayTextures::unmaskedColumns):
  // the rest of the row is black, as the kernel would write it, without reading its rays.
  constexpr size_t kLine = 64;
  const auto liveColumns = [&](int row) {
    const auto [first, last] = footprint_
                                   ? std::pair{footprint_->row(row).begin, footprint_->row(row).end}
                                   : textures_.unmaskedColumns(row);
    const int begin = std::clamp(first, x0, x1);
    return std::pair<int, int>{begin, std::clamp(last, begin, x1)};
  };
  for (int row = y0; row < y1; ++row) {
    const auto [begin, end] = liveColumns(row);
    const size_t columns = static_cast<size_t>(end - begin);
    if (columns == 0) continue;
    const auto* rays = reinterpret_cast<const char*>(&textures_.at(begin, row));
    const auto* pixels = reinterpret_cast<const char*>(&frame_->at(begin, row));
    for (size_t b = 0; b < columns * sizeof(CompactRay) + kLine - 1; b += kLine)
      __builtin_prefetch(rays + b, 0);
    for (size_t b = 0; b < columns * sizeof(Rgb) + kLine - 1; b += kLine)
      __builtin_prefetch(pixels + b, 1);
    if (cache_ && !cache_->build) {
      // The frame cache's records of these pixels (limitToStaticHits reads them next): the
      // same short rows, 12 B a pixel, and a stall on every row's first record without this.
      const auto* records = reinterpret_cast<const char*>(
          cache_->hits + static_cast<size_t>(row) * static_cast<size_t>(textures_.width()) +
          static_cast<size_t>(begin));
      for (size_t b = 0; b < columns * sizeof(StaticHit) + kLine - 1; b += kLine)
        __builtin_prefetch(records + b, 0);
    }
  }
  // The rays, row by row, by the SIMD kernel (primary_ray_kernel.h). Each starts just before
  // the scene's box rather than on the observer line, metres away: Embree intersects in float
  // relative to the origin, so a near origin keeps the hit (and the attributes interpolated
  // there) exact to float precision of the scene's size, where a far one loses digits in
  // proportion to the distance (the outer modules' rays start up to several metres to the side).
  StagedRays& staged = primaryStaged_;
  staged.reserve(capacity);
  PrimaryRayRow job;
  job.frame = textures_.frame();
  job.boundsMin = scene_.boundsMin();
  job.boundsMax = scene_.boundsMax();
  job.boxMargin = boxMargin_;
  job.background = scene_.background();
  for (int row = y0; row < y1; ++row) {
    const auto [begin, end] = liveColumns(row);
    Rgb* line = &frame_->at(0, row);
    // Outside the footprint nothing is written; its pixels are counted by renderTiles.
    if (!footprint_) {
      // Masked pixels are black: +0.0f is all zero bits, so memset writes them as whole vectors
      // where std::fill stored each 12-byte Rgb as two moves (3-5% of initialRays on demo).
      static_assert(sizeof(Rgb) == 3 * sizeof(float));
      std::memset(static_cast<void*>(line + x0), 0, sizeof(Rgb) * static_cast<size_t>(begin - x0));
      std::memset(static_cast<void*>(line + end), 0, sizeof(Rgb) * static_cast<size_t>(x1 - end));
      c->masked += (begin - x0) + (x1 - end);
    }
    if (begin == end) continue;
    job.count = end - begin;
    job.rays = &textures_.at(begin, row);
    job.out = line + begin;
    job.firstPixel = row * textures_.width() + begin;
    const PrimaryRayCounts counts = makePrimaryRays(job, &staged);
    c->masked += counts.masked;
    c->missedBounds += counts.missedBounds;
  }
  // The footprint is computed when a texture or a branch needs it (cone()); until then
  // coneWidth holds the distance skipped, which it grows over.
  const int* pixel = staged.pixels();
  const float* skipped = staged.field(StagedRays::kR);
  // Filled through a plain pointer: emplace_back reloaded the (thread-local) vector's bounds for
  // every ray. Every field is written: resize leaves the paths it adds as they are (PathVector;
  // Eigen's default constructor writes nothing either), the previous tile's are overwritten.
  paths_.resize(staged.size());
  Path* path = paths_.data();
  for (size_t i = 0; i < staged.size(); ++i) {
    Path& p = path[i];
    p.pixel = pixel[i];
    p.weight = Rgb::Ones();
    p.coneWidth = skipped[i];
    p.coneSpread = kConeUnknown;
    p.inside = -1;
  }
  rays_.assign(staged);
  c->pixels += static_cast<long>(capacity);
  c->primary += static_cast<long>(rays_.size());
}

void TileRenderer::render(int x0, int x1, int y0, int y1, RenderCounters* c) {
  PhaseClock clock(options_.timePhases, c);
  initialRays(x0, x1, y0, y1, c);
  clock.lap(RenderPhase::kGenerate);
  for (int generation = 0; generation < depth_ && !rays_.empty(); ++generation) {
    c->deepest = std::max(c->deepest, generation + 1);
    const bool coherent = generation == 0;
    if (generation == 0 && cache_ && !cache_->build) limitToStaticHits();
    if (log_) logBatch(generation, rays_);
    if (generation == 0) {
      intersectPackets(primaryScene(), rays_, options_.traversal, coherent);
    } else if (skipMeshLeft_) {
      intersectPackets(scenes_.data(), rays_, options_.traversal, coherent);
    } else {
      intersectPackets(scene_.handle(), rays_, options_.traversal, coherent);
    }
    if (generation == 0 && cache_) {
      if (cache_->build) {
        recordStaticHits();
      } else {
        takeStaticHits(c);
      }
    }
    clock.lap(RenderPhase::kIntersect);
    nextPaths_.clear();
    nextScenes_.clear();
    nextRays_.clear();
    lit_.reset(rays_.size());
    for (size_t first = 0; first < rays_.size(); first += 16) {
      const size_t end = std::min(first + 16, rays_.size());
      if (generation == 0 && end - first == 16 && shadeDiffusePacket(first / 16, c)) continue;
      for (size_t i = first; i < end; ++i) shade(i, generation, c);
    }
    if (lit_.size() > 0) {
      const bool build = cache_ && cache_->build;
      RTCScene shadowScene = build ? scene_.staticHandle() : scene_.handle();
      // Worked out once for every light's rays (makeShadowRays).
      const SurfaceSpread spread = scene_.occluders().empty() ? SurfaceSpread{} : spreadOf(lit_);
      for (size_t k = 0; k < scene_.lights().size(); ++k) {
        const PhysicalLight& light = scene_.lights()[k];
        const int index = static_cast<int>(k);
        if (build && index >= StaticHit::kCachedLights) break;  // never cached
        makeShadowRays(light, index, generation, spread, c);
        traceShadowRays(shadows_, shadowScene, coherent, generation, c, &clock);
        if (build) recordStaticShadows(shadows_, index);
        if (!dynamicShadows_.rays.empty()) {
          c->cache.shadowDynamicOnly += static_cast<long>(dynamicShadows_.rays.size());
          traceShadowRays(dynamicShadows_, scene_.dynamicHandle(), coherent, generation, c, &clock);
        }
      }
    }
    clock.lap(RenderPhase::kShade);
    std::swap(paths_, nextPaths_);
    std::swap(rays_, nextRays_);
    std::swap(scenes_, nextScenes_);
  }
}

// Every lit surface's shadow ray toward `light`, made by the SIMD kernel (shadow_ray_kernel.h).
//
// The frame cache: a surface whose static hit came from the cache has the static geometry's
// answer for a static light that has not moved: blocked (no ray), or clear (a ray against
// the dynamic instances only). Building the cache, every ray the light's direction allows is
// made, whatever the material gives it, so a later frame finds an answer for every ray it
// makes.
void TileRenderer::makeShadowRays(const PhysicalLight& light, int lightIndex, int generation,
                                  const SurfaceSpread& spread, RenderCounters* c) {
  const size_t n = lit_.size();
  const bool build = cache_ && cache_->build;
  // Rays of this light that the cache answers (first generation, a static light that stayed).
  const std::uint8_t cachedBit = cache_ && !build && generation == 0 &&
                                         lightIndex < StaticHit::kCachedLights &&
                                         (cache_->lightsValid >> lightIndex & 1u)
                                     ? static_cast<std::uint8_t>(1u << lightIndex)
                                     : 0;
  // Rays that pass every mesh's bound need no trace. A first generation's (one a pixel toward
  // this light) have their light added now, not after the traced ones, to the same sums; a later
  // generation's stay among the traced ones, parked, so that a pixel's two rays (glass's two
  // branches) add their light in the same order.
  const bool bounded = options_.boundShadowRays && !build && !scene_.occluders().empty();
  const bool parked = bounded && generation > 0;
  shadows_.staged.reserve(n);
  dynamicShadows_.staged.reserve(cachedBit ? n : 0);
  unblocked_.reserve(cachedBit || (bounded && !parked) ? n : 0);
  ShadowRayJob job;
  job.surfaces = &lit_;
  job.light = &light;
  job.worldPerPhysical = scene_.worldPerPhysical();
  job.build = build;
  job.cachedBit = cachedBit;
  job.rays = &shadows_.staged;
  job.dynamic = &dynamicShadows_.staged;
  job.unblocked = &unblocked_;
  job.spheres = scene_.dynamicSpheres().data();
  job.sphereCount = scene_.dynamicSpheres().size();
  if (bounded) {
    job.occluders = scene_.occluders().data();
    job.occluderCount = scene_.occluders().size();
    job.parkPassing = parked;
    job.spread = &spread;
  }
  const ShadowRayCounts counts = parallax::makeShadowRays(job);
  // Parked and blocked rays stay in the batch, untraced.
  shadows_.parked =
      parked ? static_cast<size_t>(counts.passedOccluders + counts.blockedByCores) : 0;
  c->cache.shadowAnswered += counts.answered;
  c->cache.shadowPassedDynamic += counts.passedDynamic;
  c->shadowPassedBounds += counts.passedOccluders;
  c->shadowBlockedByCores += counts.blockedByCores;
  // One ray a pixel toward this light, as in the batches: added now or after them, the same.
  if (unblocked_.size() > 0) addLight(unblocked_, frame_->pixels.data());
  shadows_.load(glassShadows_);
  dynamicShadows_.load(glassShadows_);
}

void TileRenderer::traceShadowRays(ShadowBatch& batch, RTCScene scene, bool coherent,
                                   int generation, RenderCounters* c, PhaseClock* clock) {
  OcclusionPackets& rays = batch.rays;
  if (rays.empty()) return;
  if (log_) logBatch(generation, rays);
  clock->lap(RenderPhase::kShade);
  Rgb* pixels = frame_->pixels.data();
  const int* pixel = batch.staged.pixels();
  float* red = batch.staged.field(StagedRays::kR);
  float* green = batch.staged.field(StagedRays::kG);
  float* blue = batch.staged.field(StagedRays::kB);
  const bool traced = rays.size() > batch.parked;  // else every ray is parked
  if (glassShadows_) {
    ShadowQueryContext query = shadowQueryContext(coherent, &scene_, batch.transmittance.data(),
                                                  batch.seen.data(), &c->glassShadowHits);
    if (traced) occludedPackets(scene, rays, options_.traversal, &query);
    clock->lap(RenderPhase::kOcclude);
    // What the glass let through, folded into the light of the rays that crossed some (most
    // cross none: no exp() for them, and their flags are skipped eight at a time); the same
    // product as contribution.cwiseProduct(factor).
    const std::uint8_t* seen = batch.seen.data();
    for (size_t i = 0; i < rays.size(); ++i) {
      if (i % 8 == 0 && i + 8 <= rays.size()) {
        std::uint64_t eight;
        std::memcpy(&eight, seen + i, sizeof(eight));
        if (eight == 0) {
          i += 7;
          continue;
        }
      }
      if (!batch.crossedGlass(i) || rays.occluded(i)) continue;
      const Rgb factor = batch.transmittance[i].factor();
      red[i] *= factor.x();
      green[i] *= factor.y();
      blue[i] *= factor.z();
    }
  } else {
    // No glass: the plain query, no per-ray state.
    if (traced) occludedPackets(scene, rays, options_.traversal, coherent);
    clock->lap(RenderPhase::kOcclude);
  }
  if (generation == 0 && options_.packetShading) {
    // One ray a pixel toward this light: whole vectors of pixels (shadow_ray_kernel.h).
    addUnblockedLight(batch.staged, rays.packets(), pixels);
  } else {
    // Later generations may bring a pixel twice (glass's two branches).
    for (size_t i = 0; i < rays.size(); ++i) {
      if (!rays.occluded(i)) pixels[pixel[i]] += Rgb(red[i], green[i], blue[i]);
    }
  }
  clock->lap(RenderPhase::kGather);
  c->shadow += static_cast<long>(rays.size() - batch.parked);
}

// Building: the static geometry's answer for each ray toward static light `lightIndex`.
// A ray through static glass leaves the pixel's lights unknown (a transmittance, not a bit).
void TileRenderer::recordStaticShadows(const ShadowBatch& batch, int lightIndex) {
  const std::uint8_t bit = static_cast<std::uint8_t>(1u << lightIndex);
  for (size_t i = 0; i < batch.rays.size(); ++i) {
    StaticHit& hit = cache_->hits[static_cast<size_t>(batch.staged.pixels()[i])];
    if (glassShadows_ && batch.crossedGlass(i)) {
      hit.setLights(0);
    } else if (!batch.rays.occluded(i) && (hit.lights() & StaticHit::kLightsKnown)) {
      hit.setLights(hit.lights() | bit);
    }
  }
}

RTCScene TileRenderer::primaryScene() const {
  if (!cache_) return scene_.handle();
  return cache_->build ? scene_.staticHandle() : scene_.dynamicHandle();
}

// The frame cache around the first generation's trace, by the SIMD kernel (static_hit_kernel.h).
StaticHitJob TileRenderer::staticHitJob() {
  StaticHitJob job;
  job.view = cache_;
  job.meshes = scene_.meshes().data();
  job.spheres = scene_.dynamicSpheres().data();
  job.sphereCount = scene_.dynamicSpheres().size();
  job.pixels = primaryStaged_.pixels();  // the rays' pixels, in order (initialRays)
  job.packets = rays_.packets();
  job.rays = rays_.size();
  job.hits = &cachedHits_;
  return job;
}

// Before the first generation is traced: each ray with a cached static hit is traced only as
// far as that hit, so the dynamic scene reports only what lies in front of it.
void TileRenderer::limitToStaticHits() {
  cachedHits_.reserve(rays_.size());
  parallax::limitToStaticHits(staticHitJob());
}

// After it: where the dynamic scene found nothing nearer, the static hit is the ray's hit.
void TileRenderer::takeStaticHits(RenderCounters* c) {
  primaryLights_.resize(std::max(primaryLights_.size(), (rays_.size() + 15) / 16 * 16));
  long reused = 0;
  const long passed = parallax::takeStaticHits(staticHitJob(), primaryLights_.data(), &reused);
  c->cache.pixelsReused += reused;
  c->cache.primaryDynamicOnly += static_cast<long>(rays_.size()) - passed;
  c->cache.primaryPassedDynamic += passed;
}

// Building: the first generation was traced against the static scene; keep its hits.
void TileRenderer::recordStaticHits() {
  const StaticVisibilityView& view = *cache_;
  for (size_t i = 0; i < rays_.size(); ++i) {
    StaticHit& hit = view.hits[static_cast<size_t>(paths_[i].pixel)];
    hit = StaticHit{};
    const unsigned geomID = rays_.geomID(i);
    if (geomID == RTC_INVALID_GEOMETRY_ID) continue;
    const int ordinal = view.staticOfMesh[geomID];
    PARALLAX_CHECK_OP(ordinal, >=, 0);
    hit.u = rays_.u(i);
    hit.v = rays_.v(i);
    hit.setTriangle(view.triangleBase[static_cast<size_t>(ordinal)] + rays_.primID(i));
  }
}

void TileRenderer::logBatch(int generation, const RayHitPackets& rays) {
  std::vector<RTCRay> copy(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) copy[i] = rays.get(i).ray;
  logBatch(false, generation, std::move(copy));
}

void TileRenderer::logBatch(int generation, const OcclusionPackets& rays) {
  std::vector<RTCRay> copy(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) copy[i] = rays.get(i);
  logBatch(true, generation, std::move(copy));
}

void TileRenderer::logBatch(bool occlusion, int generation, std::vector<RTCRay> rays) {
  RayLog::Batch batch;
  batch.occlusion = occlusion;
  batch.coherent = generation == 0;
  batch.generation = generation;
  // Logged before tracing, so each ray is replayed exactly as it was first handed to Embree.
  batch.rays = std::move(rays);
  std::lock_guard<std::mutex> lock(log_->mutex);
  log_->batches.push_back(std::move(batch));
}

Rgb TileRenderer::textureColor(const Material& m, const HitInfo& h, const Path& path, float t,
                               const Eigen::Vector3f& d, RenderCounters* c) const {
  if (m.diffuseTexture < 0) return Rgb::Ones();
  const TextureImage& image = scene_.textures()[static_cast<size_t>(m.diffuseTexture)];
  if (image.levelCount() == 0) return Rgb::Ones();  // left out (mesh without UVs)
  ++c->textureLookups;
  float lod = 0.0f;
  if (options_.textureFiltering) {
    // Ray cone: footprint width at the hit, stretched by the incidence angle, in texels.
    const float width = path.coneWidth + t * path.coneSpread;
    const float cosine = std::max(std::abs(d.dot(h.geometricNormal)), 0.05f);
    const float texelsPerMetre = std::sqrt(h.texelsPerMetreSq * static_cast<float>(image.width()) *
                                           static_cast<float>(image.height()));
    lod = std::log2(std::max(width * texelsPerMetre / cosine, 1e-30f));
  }
  return image.lookup(h.uv.x(), h.uv.y(), lod);
}

void TileRenderer::pushBranch(const Path& parent, const Rgb& weight, const Eigen::Vector3f& origin,
                              const Eigen::Vector3f& dir, int inside, float coneWidth, int meshLeft,
                              RenderCounters* c) {
  if (weight.maxCoeff() < options_.minWeight) {
    ++c->pruned;
    return;
  }
  Path child = parent;
  child.weight = weight;
  child.inside = inside;
  child.coneWidth = coneWidth;
  nextPaths_.push_back(child);
  nextRays_.push(origin, dir);
  if (!skipMeshLeft_) return;
  if (meshLeft >= 0) {
    nextScenes_.push_back(scene_.withoutMesh(static_cast<unsigned>(meshLeft)));
    ++c->withoutMeshLeft;
  } else {
    nextScenes_.push_back(scene_.handle());
  }
}

// The mesh a reflection or refraction ray leaves, when it may be traced without it: the ray
// starts on the `frontSide` (the CCW side) of triangle `prim`, offset along `side` (that side's
// unit normal), and moves away from the triangle's plane, on whose other side the whole mesh
// lies (a bare face, PhysicalMesh::bareFaces), so it cannot meet the mesh again. -1 otherwise,
// or when the mesh has no scene without it.
int TileRenderer::meshLeft(unsigned geomID, unsigned prim, bool frontSide,
                           const Eigen::Vector3f& side, const Eigen::Vector3f& dir) const {
  if (!skipMeshLeft_ || !scene_.withoutMesh(geomID)) return -1;
  return scene_.meshes()[geomID].bareOn(prim, frontSide) && dir.dot(side) > 0.0f
             ? static_cast<int>(geomID)
             : -1;
}

// With the frame cache, a first-generation diffuse hit's answers for the static lights (its
// LitSurfaces flag bits): building, known, as the shadow rays about to be traced answer them;
// else what the cache held for primary ray `ray` (takeStaticHits).
std::uint8_t TileRenderer::cachedStaticLights(size_t ray, int pixel) {
  if (!cache_->build) return primaryLights_[ray];
  cache_->hits[static_cast<size_t>(pixel)].setLights(StaticHit::kLightsKnown);
  return StaticHit::kLightsKnown;
}

void TileRenderer::shade(size_t i, int generation, RenderCounters* c) {
  Path& path = paths_[i];
  Rgb& out = frame_->pixels[static_cast<size_t>(path.pixel)];
  const unsigned geomID = rays_.geomID(i);
  if (geomID == RTC_INVALID_GEOMETRY_ID) {
    out += path.weight.cwiseProduct(scene_.background());
    return;
  }
  const Eigen::Vector3f d = rays_.direction(i);
  const float t = rays_.tfar(i);
  const PhysicalMesh& mesh = scene_.meshes()[geomID];
  const Material& m = scene_.materials()[static_cast<size_t>(mesh.material)];
  const HitInfo h =
      hitInfoOf(mesh, rays_.primID(i), rays_.u(i), rays_.v(i), d, m.diffuseTexture >= 0);
  // Primary rays get their footprint only here, and only when a texture or a branch uses it.
  if (path.coneSpread == kConeUnknown && texturesUsed_ &&
      (m.diffuseTexture >= 0 || m.kind == MaterialKind::kMirror ||
       m.kind == MaterialKind::kDielectric)) {
    cone(path.pixel, &path);
  }
  Rgb weight = path.weight;
  if (path.inside >= 0) {
    // Beer–Lambert over the distance travelled inside the glass, in world units.
    const Material& glass = scene_.materials()[static_cast<size_t>(path.inside)];
    const float distance = t * scene_.worldPerPhysical();
    weight = weight.cwiseProduct((-glass.absorption * distance).array().exp().matrix());
  }
  const bool canBranch = generation + 1 < depth_;
  const float coneWidth = path.coneWidth + t * std::max(path.coneSpread, 0.0f);

  if (m.emission.maxCoeff() > 0.0f || m.kind == MaterialKind::kEmissive) {
    Rgb e = m.emission.cwiseProduct(h.vertexColor);
    if (m.kind == MaterialKind::kEmissive) e = e.cwiseProduct(textureColor(m, h, path, t, d, c));
    out += weight.cwiseProduct(e);
  }
  switch (m.kind) {
    case MaterialKind::kEmissive:
      return;
    case MaterialKind::kDiffuse: {
      Rgb albedo = m.diffuse.cwiseProduct(h.vertexColor);
      if (m.diffuseTexture >= 0) albedo = albedo.cwiseProduct(textureColor(m, h, path, t, d, c));
      const Rgb weightedAlbedo = weight.cwiseProduct(albedo);
      out += weightedAlbedo.cwiseProduct(scene_.ambient());
      if (scene_.lights().empty()) return;
      const std::uint8_t staticLights =
          generation == 0 && cache_ ? cachedStaticLights(i, path.pixel) : 0;
      const unsigned prim = rays_.primID(i);
      const bool leavesMesh = mesh.bareOn(prim, h.frontFace);
      lit_.push(h.position, h.shadingNormal, h.geometricNormal, weightedAlbedo, path.pixel,
                staticLights, LitSurfaces::meshFlags(geomID, leavesMesh));
      if (m.specular.maxCoeff() > 0.0f) {
        lit_.setHighlight(reflect(d, h.shadingNormal), weight.cwiseProduct(m.specular),
                          m.shininess);
      }
      return;
    }
    case MaterialKind::kMirror: {
      if (!canBranch) return;
      ++c->reflection;
      const Eigen::Vector3f above = offsetRayOrigin(h.position, h.geometricNormal);
      const Eigen::Vector3f reflected = reflect(d, h.shadingNormal);
      pushBranch(path, weight.cwiseProduct(m.reflectance), above, reflected, path.inside, coneWidth,
                 meshLeft(geomID, rays_.primID(i), h.frontFace, h.geometricNormal, reflected), c);
      return;
    }
    case MaterialKind::kDielectric: {
      if (!canBranch) return;
      // Entering through the front face (the CCW side, outward for closed meshes) goes from air
      // into the glass; leaving through the back face goes out.
      const float eta = h.frontFace ? 1.0f / m.ior : m.ior;
      const Eigen::Vector3f& n = h.shadingNormal;
      Eigen::Vector3f refracted;
      float cosT = 0.0f;
      const float cosI = std::min(1.0f, -d.dot(n));
      const bool transmits = refract(d, n, eta, &refracted, &cosT);
      const float reflectance = transmits ? fresnelDielectric(cosI, cosT, eta) : 1.0f;
      ++c->reflection;
      const unsigned prim = rays_.primID(i);
      const Eigen::Vector3f above = offsetRayOrigin(h.position, h.geometricNormal);
      const Eigen::Vector3f reflected = reflect(d, n);
      pushBranch(path, weight * reflectance, above, reflected, path.inside, coneWidth,
                 meshLeft(geomID, prim, h.frontFace, h.geometricNormal, reflected), c);
      if (transmits) {
        ++c->refraction;
        const Eigen::Vector3f below = offsetRayOrigin(h.position, -h.geometricNormal);
        pushBranch(path, weight * (1.0f - reflectance), below, refracted,
                   h.frontFace ? mesh.material : -1, coneWidth,
                   meshLeft(geomID, prim, !h.frontFace, -h.geometricNormal, refracted), c);
      }
      return;
    }
  }
}

// The commonest packet: all 16 rays met one plain diffuse mesh (no vertex colours, no
// emission). The kernel without masks and the ambient term computed once; false when the packet
// is not of this kind.
bool TileRenderer::shadeOneMeshPacket(size_t packet, RenderCounters* c) {
  const RTCRayHit16& hits = rays_.packets()[packet];
  const unsigned geomID = hits.hit.geomID[0];
  if (geomID == RTC_INVALID_GEOMETRY_ID) return false;
  for (int lane = 1; lane < 16; ++lane)
    if (hits.hit.geomID[lane] != geomID) return false;
  const PhysicalMesh& mesh = scene_.meshes()[geomID];
  const Material& m = scene_.materials()[static_cast<size_t>(mesh.material)];
  if (m.kind != MaterialKind::kDiffuse || m.emission.maxCoeff() > 0.0f || !mesh.colors.empty())
    return false;
  const size_t first = lit_.size();
  if (!parallax::shadeDiffusePacket(hits, geomID, mesh, m, &lit_, first, true)) return false;
  lit_.extend(16);
  if (m.diffuseTexture >= 0) textureDiffusePacket(packet, geomID, mesh, m, first, c);
  // What shade() adds at once: the ambient term (a first-generation weight is 1), and the
  // frame cache's answers for the static lights.
  const Rgb ambient = m.diffuse.cwiseProduct(scene_.ambient());
  std::int32_t* flags = lit_.mutableFlags() + first;
  int* pixels = lit_.mutablePixels() + first;
  for (size_t lane = 0; lane < 16; ++lane) {
    const size_t i = 16 * packet + lane;
    const int pixel = paths_[i].pixel;
    if (m.diffuseTexture < 0) frame_->pixels[static_cast<size_t>(pixel)] += ambient;
    pixels[lane] = pixel;
    if (!cache_) continue;
    flags[lane] |= static_cast<std::int32_t>(cachedStaticLights(i, pixel))
                   << LitSurfaces::kStaticLightsShift;
  }
  return true;
}

// A first-generation packet whose rays met plain diffuse meshes (no vertex colours, no
// emission; one, or up to kPacketMeshes of them, textured or not) or missed, by the SIMD kernel
// (diffuse_hit_kernel.h, a call a mesh); the misses get the background and no lit surface, as in
// shade(). false leaves the packet to shade().
bool TileRenderer::shadeDiffusePacket(size_t packet, RenderCounters* c) {
  constexpr int kPacketMeshes = 4;
  constexpr int kMiss = -1;
  if (!options_.packetShading || scene_.lights().empty()) return false;
  const RTCRayHit16& hits = rays_.packets()[packet];
  if (shadeOneMeshPacket(packet, c)) return true;
  unsigned meshes[kPacketMeshes];
  int slot[16];  // per lane: its mesh's index in meshes, or kMiss
  int meshCount = 0;
  bool missed = false;
  for (int lane = 0; lane < 16; ++lane) {
    const unsigned geomID = hits.hit.geomID[lane];
    int k = 0;
    while (k < meshCount && meshes[k] != geomID) ++k;
    if (geomID == RTC_INVALID_GEOMETRY_ID) {
      missed = true;
      k = kMiss;
    } else if (k == meshCount) {
      if (meshCount == kPacketMeshes) return false;
      meshes[meshCount++] = geomID;
    }
    slot[lane] = k;
  }
  if (meshCount == 0) return false;  // all missed: shade() only adds the background
  // Per mesh, what shade() adds at once to an untextured hit's pixel: the ambient term (a
  // first-generation weight is 1); a textured one's comes with its texture colour.
  Rgb ambient[kPacketMeshes];
  bool textured[kPacketMeshes];
  for (int k = 0; k < meshCount; ++k) {
    const PhysicalMesh& mesh = scene_.meshes()[meshes[k]];
    const Material& m = scene_.materials()[static_cast<size_t>(mesh.material)];
    if (m.kind != MaterialKind::kDiffuse || m.emission.maxCoeff() > 0.0f || !mesh.colors.empty())
      return false;
    ambient[k] = m.diffuse.cwiseProduct(scene_.ambient());
    textured[k] = m.diffuseTexture >= 0;
  }
  const size_t first = lit_.size();
  for (int k = 0; k < meshCount; ++k) {
    const PhysicalMesh& mesh = scene_.meshes()[meshes[k]];
    const Material& m = scene_.materials()[static_cast<size_t>(mesh.material)];
    if (!parallax::shadeDiffusePacket(hits, meshes[k], mesh, m, &lit_, first, false)) return false;
    if (textured[k]) textureDiffusePacket(packet, meshes[k], mesh, m, first, c);
  }
  // A miss gets the background, as in shade(), and its lane is closed up: the surfaces stay in
  // ray order. A hit gets the frame cache's answers for the static lights.
  const Path* paths = paths_.data() + 16 * packet;
  Rgb* frame = frame_->pixels.data();
  std::int32_t* flags = lit_.mutableFlags();
  int* pixels = lit_.mutablePixels();
  size_t surface = first;
  for (size_t lane = 0; lane < 16; ++lane) {
    const int pixel = paths[lane].pixel;
    const int k = slot[lane];
    if (k == kMiss) {
      frame[pixel] += paths[lane].weight.cwiseProduct(scene_.background());
      continue;
    }
    if (!textured[k]) frame[pixel] += ambient[k];
    if (missed && surface != first + lane) lit_.copy(first + lane, surface);
    pixels[surface] = pixel;
    if (cache_) {
      flags[surface] |= static_cast<std::int32_t>(cachedStaticLights(16 * packet + lane, pixel))
                        << LitSurfaces::kStaticLightsShift;
    }
    ++surface;
  }
  lit_.extend(surface - first);
  return true;
}

// The lanes of a textured mesh after the kernel: each one's texture colour (hitInfoOf's uv and
// texel density, the pixel's footprint, the filtered lookup: textureColor, as shade() does, by
// the SIMD kernel of texture_lookup_kernel.h) times the material's colour, into the lit
// surface's albedo and, with the ambient light, the pixel.
void TileRenderer::textureDiffusePacket(size_t packet, unsigned geomID, const PhysicalMesh& mesh,
                                        const Material& m, size_t first, RenderCounters* c) {
  float* albedo[3] = {lit_.mutableField(LitSurfaces::kDr) + first,
                      lit_.mutableField(LitSurfaces::kDg) + first,
                      lit_.mutableField(LitSurfaces::kDb) + first};
  const TextureImage& image = scene_.textures()[static_cast<size_t>(m.diffuseTexture)];
  if (image.levelCount() == 0 || mesh.uvs.empty()) {
    // Left out (a mesh without uvs): textureColor's white, lane by lane.
    for (size_t lane = 0; lane < 16; ++lane) {
      const size_t i = 16 * packet + lane;
      if (rays_.geomID(i) != geomID) continue;
      Path& path = paths_[i];
      const unsigned prim = rays_.primID(i);
      HitInfo h;
      h.geometricNormal = mesh.faceNormals[prim];  // toward the ray or not: only |d · n| is used
      textureCoordinatesOf(mesh, prim, rays_.u(i), rays_.v(i), &h);
      if (path.coneSpread == kConeUnknown && texturesUsed_) cone(path.pixel, &path);
      const Rgb weightedAlbedo =
          m.diffuse.cwiseProduct(textureColor(m, h, path, rays_.tfar(i), rays_.direction(i), c));
      for (int k = 0; k < 3; ++k) albedo[k][lane] = weightedAlbedo[k];
      frame_->pixels[static_cast<size_t>(path.pixel)] +=
          weightedAlbedo.cwiseProduct(scene_.ambient());
    }
    return;
  }
  // The footprints as vectors (the kernel computes those not known yet, as cone() does).
  alignas(64) float coneWidth[16], coneSpread[16], colour[3][16];
  alignas(64) std::int32_t coneUnknown[16], pixel[16];
  for (size_t lane = 0; lane < 16; ++lane) {
    const Path& path = paths_[16 * packet + lane];
    coneWidth[lane] = path.coneWidth;
    coneSpread[lane] = path.coneSpread;
    coneUnknown[lane] = path.coneSpread == kConeUnknown && texturesUsed_ ? 1 : 0;
    pixel[lane] = path.pixel;
  }
  TextureLanes job;
  job.packet = &rays_.packets()[packet];
  job.geomID = geomID;
  job.mesh = &mesh;
  job.image = &image;
  job.filtering = options_.textureFiltering;
  job.coneWidth = coneWidth;
  job.coneSpread = coneSpread;
  job.coneUnknown = coneUnknown;
  job.pixel = pixel;
  job.textures = &textures_;
  for (int k = 0; k < 3; ++k) job.color[k] = colour[k];
  lookUpTextures(job);
  for (size_t lane = 0; lane < 16; ++lane) {
    const size_t i = 16 * packet + lane;
    if (rays_.geomID(i) != geomID) continue;
    paths_[i].coneWidth = coneWidth[lane];
    paths_[i].coneSpread = coneSpread[lane];
    ++c->textureLookups;
    const Rgb weightedAlbedo =
        m.diffuse.cwiseProduct(Rgb(colour[0][lane], colour[1][lane], colour[2][lane]));
    for (int k = 0; k < 3; ++k) albedo[k][lane] = weightedAlbedo[k];
    frame_->pixels[static_cast<size_t>(paths_[i].pixel)] +=
        weightedAlbedo.cwiseProduct(scene_.ambient());
  }
}

// The calling worker's buffers. A tile never waits on other TBB work, so no two tiles share
// them at the same time.
TileBuffers& threadBuffers() {
  thread_local TileBuffers buffers;
  return buffers;
}

}  // namespace

void RenderOptions::validate() const {
  if (tileWidth < 1 || tileWidth > 4096)
    throw InputError({"", "tile_width", 0}, "must be in 1..4096");
  if (tileHeight < 1 || tileHeight > 4096)
    throw InputError({"", "tile_height", 0}, "must be in 1..4096");
  if (!std::isfinite(minWeight) || minWeight < 0.0f || minWeight >= 1.0f) {
    throw InputError({"", "min_weight", 0}, "must be in [0, 1)");
  }
  if (maxDepth < 0 || maxDepth > 64)
    throw InputError({"", "max_depth", 0}, "must be in 0..64 (0: the scene's)");
  const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(samplesPerPixel))));
  if (samplesPerPixel < 1 || samplesPerPixel > 256 || side * side != samplesPerPixel) {
    throw InputError({"", "samples_per_pixel", 0},
                     "must be a square in 1..256 (an n x n sub-pixel grid)");
  }
}

const char* renderPhaseName(RenderPhase phase) {
  switch (phase) {
    case RenderPhase::kGenerate:
      return "generate";
    case RenderPhase::kIntersect:
      return "intersect";
    case RenderPhase::kShade:
      return "shade";
    case RenderPhase::kOcclude:
      return "occlude";
    case RenderPhase::kGather:
      return "gather";
  }
  return "?";
}

RenderCounters& RenderCounters::operator+=(const RenderCounters& o) {
  pixels += o.pixels;
  masked += o.masked;
  missedBounds += o.missedBounds;
  primary += o.primary;
  shadow += o.shadow;
  reflection += o.reflection;
  refraction += o.refraction;
  pruned += o.pruned;
  glassShadowHits += o.glassShadowHits;
  shadowPassedBounds += o.shadowPassedBounds;
  outsideFootprint += o.outsideFootprint;
  shadowBlockedByCores += o.shadowBlockedByCores;
  textureLookups += o.textureLookups;
  withoutMeshLeft += o.withoutMeshLeft;
  cache += o.cache;
  deepest = std::max(deepest, o.deepest);
  for (int i = 0; i < kRenderPhases; ++i) phaseThreadMs[i] += o.phaseThreadMs[i];
  return *this;
}

std::vector<std::string> RenderCounters::lines() const {
  std::vector<std::string> out = {
      fmt::format(
          "  pixels {}: {} masked (never traced), {} miss the scene's bounds (never traversed)",
          pixels, masked, missedBounds),
      fmt::format("  rays {}: primary {}, shadow {}, reflection {}, refraction {}", rays(), primary,
                  shadow, reflection, refraction),
      fmt::format(
          "  branches pruned below the weight limit {}; texture lookups {}; deepest generation {}",
          pruned, textureLookups, deepest),
      fmt::format("  glass surfaces shadow rays passed through {} (the glass filter's calls)",
                  glassShadowHits),
      fmt::format("  shadow rays not traced: {} pass every object's bounds, {} go through the core "
                  "of a closed convex object (blocked)",
                  shadowPassedBounds, shadowBlockedByCores),
  };
  if (withoutMeshLeft > 0) {
    out.push_back(fmt::format(
        "  reflection and refraction rays traced without the mirror or glass they leave: {}",
        withoutMeshLeft));
  }
  if (outsideFootprint > 0) {
    out.push_back(fmt::format(
        "  pixels outside the scene's footprint (neither read nor written, their bytes kept from "
        "before): {}",
        outsideFootprint));
  }
  double phaseTotal = 0.0;
  for (double ms : phaseThreadMs) phaseTotal += ms;
  if (phaseTotal > 0.0) {
    std::string split = fmt::format("  thread time {:.0f} ms:", phaseTotal);
    for (int i = 0; i < kRenderPhases; ++i) {
      split += fmt::format(" {} {:.0f}{}", renderPhaseName(static_cast<RenderPhase>(i)),
                           phaseThreadMs[i], i + 1 < kRenderPhases ? "," : "");
    }
    out.push_back(split);
  }
  if (cache.pixelsReused + cache.primaryDynamicOnly > 0) {
    out.push_back(fmt::format(
        "  frame cache: {} primary hits reused ({} primary rays traced against the dynamic "
        "objects only, {} passing every dynamic object's bounds: not traced); shadow rays: {} "
        "answered without tracing, {} passing every dynamic object's bounds (not traced), {} "
        "traced against the dynamic objects only",
        cache.pixelsReused, cache.primaryDynamicOnly, cache.primaryPassedDynamic,
        cache.shadowAnswered, cache.shadowPassedDynamic, cache.shadowDynamicOnly));
  }
  return out;
}

namespace {

struct TileBounds {
  int x0, x1, y0, y1;
};

// The tiles (options' size, laid from the frame's top-left corner) that hold some column of the
// footprint's rows, and in `outside` the counts of every pixel outside it (masked or missing
// the scene's box), with the pixels of the tiles left out.
std::vector<TileBounds> footprintTiles(const SceneFootprint& footprint,
                                       const RenderOptions& options, RenderCounters* outside) {
  std::vector<TileBounds> tiles;
  const int width = footprint.width(), height = footprint.height();
  for (int y0 = 0; y0 < height; y0 += options.tileHeight) {
    const int y1 = std::min(height, y0 + options.tileHeight);
    int first = width, last = 0;
    for (int y = y0; y < y1; ++y) {
      const FootprintRow& row = footprint.row(y);
      outside->masked += row.masked;
      outside->missedBounds += row.missed;
      outside->outsideFootprint += row.masked + row.missed;
      if (row.begin < row.end) {
        first = std::min(first, row.begin);
        last = std::max(last, row.end);
      }
    }
    for (int x0 = 0; x0 < width; x0 += options.tileWidth) {
      const int x1 = std::min(width, x0 + options.tileWidth);
      if (x1 > first && x0 < last) {
        tiles.push_back({x0, x1, y0, y1});
      } else {
        outside->pixels += static_cast<long>(x1 - x0) * (y1 - y0);
      }
    }
  }
  return tiles;
}

void renderTiles(const PhysicalScene& scene, const RayTextures& textures,
                 const RenderOptions& options, Frame* frame, RenderCounters* counters, RayLog* log,
                 const StaticVisibilityView* cache, const SceneFootprint* footprint = nullptr,
                 const TileDone* tileDone = nullptr) {
  options.validate();
  if (options.samplesPerPixel != 1) {
    throw InputError(
        {"", "samples_per_pixel", 0},
        "sub-pixel rays need the display model: renderFrameInto of supersampled_render.h");
  }
  if (frame->width != textures.width() || frame->height != textures.height() ||
      frame->pixels.size() !=
          static_cast<size_t>(textures.width()) * static_cast<size_t>(textures.height())) {
    *frame = Frame(textures.width(), textures.height());
  }
  int depth = scene.features().depth;
  if (options.maxDepth > 0) depth = std::min(depth, options.maxDepth);
  if (footprint) {
    PARALLAX_CHECK_OP(footprint->width(), ==, textures.width());
    PARALLAX_CHECK_OP(footprint->height(), ==, textures.height());
    PARALLAX_CHECK(footprint->holds(scene.boundsMin(), scene.boundsMax()));
  }
  if (cache) {
    PARALLAX_CHECK(scene.split());
    PARALLAX_CHECK(!cache->build || scene.staticHandle() != nullptr);
    if (cache->build) depth = 1;  // the primary hits and their shadow rays only
  }
  tbb::combinable<RenderCounters> perThread;
  const auto renderTile = [&](const TileBounds& t) {
    TileRenderer renderer(scene, textures, options, depth, frame, log, &threadBuffers(), cache,
                          footprint);
    renderer.render(t.x0, t.x1, t.y0, t.y1, &perThread.local());
    if (tileDone) (*tileDone)(t.x0, t.x1, t.y0, t.y1);
  };
  RenderCounters outside;
  if (footprint) {
    // Only the tiles that hold some of the footprint: on an animated scene three quarters of a
    // module's tiles hold none, and each cost a task, a renderer and an encode call for nothing.
    const std::vector<TileBounds> tiles = footprintTiles(*footprint, options, &outside);
    tbb::parallel_for(
        size_t{0}, tiles.size(), [&](size_t i) { renderTile(tiles[i]); },
        tbb::simple_partitioner());
  } else {
    const tbb::blocked_range2d<int> range(0, textures.height(), options.tileHeight, 0,
                                          textures.width(), options.tileWidth);
    tbb::parallel_for(
        range,
        [&](const tbb::blocked_range2d<int>& tile) {
          renderTile(
              {tile.cols().begin(), tile.cols().end(), tile.rows().begin(), tile.rows().end()});
        },
        tbb::simple_partitioner());
  }
  if (counters) {
    *counters = outside;
    perThread.combine_each([&](const RenderCounters& c) { *counters += c; });
  }
}

}  // namespace

void renderFrameInto(const PhysicalScene& scene, const RayTextures& textures,
                     const RenderOptions& options, Frame* frame, RenderCounters* counters,
                     RayLog* log) {
  renderTiles(scene, textures, options, frame, counters, log, nullptr);
}

void renderFrameInto(const PhysicalScene& scene, const RayTextures& textures,
                     const RenderOptions& options, const StaticVisibilityView& cache, Frame* frame,
                     RenderCounters* counters) {
  renderTiles(scene, textures, options, frame, counters, nullptr, &cache);
}

void renderFrameInto(const PhysicalScene& scene, const RayTextures& textures,
                     const RenderOptions& options, const SceneFootprint& footprint,
                     const StaticVisibilityView* cache, Frame* frame, RenderCounters* counters,
                     const TileDone* tileDone) {
  renderTiles(scene, textures, options, frame, counters, nullptr, cache, &footprint, tileDone);
}

Frame renderFrame(const PhysicalScene& scene, const RayTextures& textures,
                  const RenderOptions& options, RenderCounters* counters, RayLog* log) {
  Frame frame;
  renderFrameInto(scene, textures, options, &frame, counters, log);
  return frame;
}

}  // namespace parallax
