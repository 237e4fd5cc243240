#include "tracer/frame_cache.h"

#include <fmt/format.h>
#include <malloc.h>

#include <algorithm>
#include <bit>
#include <chrono>

#include "common/content_checksum.h"
#include "tracer/frame.h"

namespace parallax {
namespace {

template <class T>
void mix(std::uint64_t* hash, const std::vector<T>& values) {
  const std::uint64_t h = values.empty() ? 0 : fnv1a64(values.data(), values.size() * sizeof(T));
  *hash = (*hash ^ h) * 0x100000001b3ull ^ values.size();
}

bool sameLight(const PhysicalLight& a, const PhysicalLight& b) {
  // Only where the light comes from decides what blocks it; its colour may change freely.
  return a.kind == b.kind && a.toLight == b.toLight && a.position == b.position;
}

}  // namespace

std::vector<std::string> FrameCacheStats::lines() const {
  std::vector<std::string> out = {
      fmt::format("  frame cache: {} builds (last {:.1f} ms, all {:.1f} ms), {} frames through "
                  "it, {} without ({})",
                  builds, lastBuildMs, buildMs, framesCached, framesBypassed,
                  lastRebuild.empty() ? "never stale" : "last: " + lastRebuild),
      fmt::format("  frame cache memory: {:.1f} MiB for {} pixels ({:.1f} B a pixel); {} static "
                  "and {} dynamic objects, {} static lights cached",
                  static_cast<double>(bytes) / (1024.0 * 1024.0), pixels, bytesPerPixel(),
                  staticInstances, dynamicInstances, cachedLights),
      fmt::format("  frame cache saved: {} primary hits reused, {} shadow rays not traced (a "
                  "static surface blocks them), {} not traced (they pass every moving object's "
                  "bounds), {} traced against the moving objects only",
                  saved.pixelsReused, saved.shadowAnswered, saved.shadowPassedDynamic,
                  saved.shadowDynamicOnly),
  };
  out.push_back(fmt::format(
      "  frame cache payoff: {} ({} frames re-traced in full to measure it; {:.1f} MiB freed in "
      "all)",
      payoff.empty() ? "not measured yet" : payoff, framesMeasured,
      static_cast<double>(bytesFreed) / (1024.0 * 1024.0)));
  return out;
}

const std::vector<bool>& FrameCache::dynamicInstances(const Scene& scene) {
  const size_t n = scene.instances.size();
  bool layoutChanged = instanceMesh_.size() != n;
  for (size_t i = 0; i < n && !layoutChanged; ++i)
    layoutChanged = instanceMesh_[i] != scene.instances[i].mesh;
  if (layoutChanged) {
    // Another scene (a reload that added or dropped objects): start again from its hints.
    instanceMesh_.resize(n);
    for (size_t i = 0; i < n; ++i) instanceMesh_[i] = scene.instances[i].mesh;
    dynamic_.assign(n, false);
  }
  for (int i : scene.movedInstances) {
    if (i >= 0 && static_cast<size_t>(i) < n) dynamic_[static_cast<size_t>(i)] = true;
  }
  // An instance that moved without being named (a transform set some other way, a script
  // that moves an object only later): dynamic from now on.
  std::vector<Eigen::Matrix<double, 3, 4>> transforms(n);
  for (size_t i = 0; i < n; ++i) {
    transforms[i] = scene.instances[i].worldFromObject.matrix().topRows<3>();
    if (!layoutChanged && transforms[i] != lastTransforms_[i]) dynamic_[i] = true;
  }
  lastTransforms_ = std::move(transforms);
  return dynamic_;
}

void FrameCache::mapStaticMeshes(const PhysicalScene& scene) {
  const std::vector<int>& meshes = scene.instanceMeshes();
  staticInstances_.clear();
  triangleBase_.assign(1, 0);
  meshOfStatic_.clear();
  staticOfMesh_.assign(scene.meshes().size(), -1);
  std::uint64_t total = 0;
  for (size_t i = 0; i < meshes.size(); ++i) {
    if (scene.dynamicInstance(static_cast<int>(i))) continue;
    const int mesh = meshes[i];
    if (mesh >= 0)
      staticOfMesh_[static_cast<size_t>(mesh)] = static_cast<int>(meshOfStatic_.size());
    staticInstances_.push_back(static_cast<int>(i));
    meshOfStatic_.push_back(mesh);
    total += mesh >= 0 ? scene.meshes()[static_cast<size_t>(mesh)].triangles.size() : 0;
    // Saturates instead of wrapping: prepare() refuses more than StaticHit::kMaxTriangles.
    triangleBase_.push_back(
        static_cast<std::uint32_t>(std::min<std::uint64_t>(total, 0xFFFFFFFFu)));
  }
}

std::uint64_t FrameCache::staticHash(const PhysicalScene& scene) const {
  std::uint64_t hash = 0xcbf29ce484222325ull;
  for (int mesh : meshOfStatic_) {
    if (mesh < 0) {
      hash = (hash ^ 0x9e3779b97f4a7c15ull) * 0x100000001b3ull;
      continue;
    }
    const PhysicalMesh& m = scene.meshes()[static_cast<size_t>(mesh)];
    mix(&hash, m.positions);
    mix(&hash, m.triangles);
    mix(&hash, m.normals);
  }
  return hash;
}

bool FrameCache::prepare(PhysicalScene& scene, const std::vector<RayTextures>& textures,
                         std::uint64_t texturesVersion, const RenderOptions& options) {
  ++frame_;
  frameKind_ = kUntimed;
  mapStaticMeshes(scene);
  stats_.staticInstances = static_cast<int>(staticInstances_.size());
  stats_.dynamicInstances =
      static_cast<int>(scene.instanceMeshes().size() - staticInstances_.size());
  const std::uint64_t triangles = triangleBase_.back();
  if (!scene.split() || triangles == 0 || triangles >= StaticHit::kMaxTriangles) {
    ++stats_.framesBypassed;
    stats_.lastRebuild = triangles == 0 ? "no static geometry: nothing to keep"
                                        : "more static triangles than a record can name";
    clear();
    return false;
  }
  const std::uint64_t hash = staticHash(scene);
  std::string stale;
  if (stats_.declined) {
    if (dynamic_ == declinedDynamic_ && hash == declinedHash_ &&
        texturesVersion == declinedTexturesVersion_) {
      ++stats_.framesBypassed;
      return false;
    }
    // What it did not pay for has changed: try it again.
    stats_.declined = false;
    stale = "the scene changed since the cache did not pay";
  }
  bool texturesSame =
      built_ && texturesVersion == builtTexturesVersion_ && records_.size() == textures.size();
  for (size_t m = 0; texturesSame && m < textures.size(); ++m) {
    texturesSame = records_[m].size() == static_cast<size_t>(textures[m].width()) *
                                             static_cast<size_t>(textures[m].height());
  }
  if (!stale.empty()) {
    // (said above)
  } else if (!built_) {
    stale = "first frame";
  } else if (builtDynamic_ != dynamic_) {
    stale = "an object held static moved";
  } else if (hash != builtHash_) {
    stale = "the static geometry changed (a reload, the world box)";
  } else if (!texturesSame) {
    stale = "the ray textures changed";
  }
  if (!stale.empty()) {
    ++staleFrames_;
    if (frame_ < nextBuildFrame_) {
      ++stats_.framesBypassed;
      stats_.lastRebuild = stale + "; stale frame after frame, so rebuilt only now and then";
      return false;
    }
    // Stale again right after a build: wait twice as long each time (up to 32 frames).
    nextBuildFrame_ = frame_ + (1l << std::min(staleFrames_ - 1, 5));
    build(scene, textures, options);
    builtHash_ = hash;
    builtTexturesVersion_ = texturesVersion;
    stats_.lastRebuild = stale;
    // A new basis: whether it pays is measured again (the build's own frame is not a sample).
    trial_ = true;
    cachedCost_.clear();
    fullCost_.clear();
  } else {
    staleFrames_ = 0;
    if (trial_ && cachedCost_.size() > fullCost_.size()) {
      // The trial's full re-trace of this frame (the same image; the records stay).
      frameKind_ = kTrialFull;
      ++stats_.framesBypassed;
      ++stats_.framesMeasured;
      return false;
    }
    frameKind_ = kCached;
  }
  lightsValid_ = 0;
  const size_t lights = std::min<size_t>(scene.lights().size(), StaticHit::kCachedLights);
  for (size_t k = 0; k < lights && k < builtLights_.size(); ++k) {
    if (sameLight(scene.lights()[k], builtLights_[k]))
      lightsValid_ = static_cast<std::uint8_t>(lightsValid_ | (1u << k));
  }
  stats_.cachedLights = std::popcount(lightsValid_);
  ++stats_.framesCached;
  return true;
}

void FrameCache::reportFrameCost(double cpuMs) {
  if (!trial_ || frameKind_ == kUntimed) return;
  (frameKind_ == kCached ? cachedCost_ : fullCost_).push_back(cpuMs);
  frameKind_ = kUntimed;
  if (cachedCost_.size() >= kTrialFrames && fullCost_.size() >= kTrialFrames) judge();
}

void FrameCache::judge() {
  trial_ = false;
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const double cached = median(cachedCost_), full = median(fullCost_);
  const double gain = cached > 0.0 ? full / cached : 0.0;
  const std::string measured = fmt::format(
      "{:.1f} ms CPU a frame through it, {:.1f} ms without ({:.2f}x; medians of {} frames each)",
      cached, full, gain, kTrialFrames);
  if (gain >= kMinGain) {
    stats_.payoff = "pays: " + measured;
    return;
  }
  stats_.payoff = fmt::format(
      "does not pay: {}, under {:.2f}x; its {:.1f} MiB freed, frames rendered in full until the "
      "static geometry, the moving objects or the ray textures change",
      measured, kMinGain, static_cast<double>(stats_.bytes) / (1024.0 * 1024.0));
  stats_.bytesFreed += stats_.bytes;
  declinedDynamic_ = builtDynamic_;
  declinedHash_ = builtHash_;
  declinedTexturesVersion_ = builtTexturesVersion_;
  dropRecords();
  // Back to the system, not only to the allocator: glibc keeps freed heap pages mapped (on
  // `default` 648 MiB the daemon would go on holding).
  malloc_trim(0);
  stats_.declined = true;
}

void FrameCache::build(PhysicalScene& scene, const std::vector<RayTextures>& textures,
                       const RenderOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  scene.buildStaticScene();
  records_.resize(textures.size());
  stats_.pixels = 0;
  stats_.bytes = 0;
  Frame scratch;  // the build's shading lands here and is dropped
  RenderOptions buildOptions = options;
  buildOptions.timePhases = false;
  for (size_t m = 0; m < textures.size(); ++m) {
    const size_t pixels =
        static_cast<size_t>(textures[m].width()) * static_cast<size_t>(textures[m].height());
    records_[m].assign(pixels, StaticHit{});
    records_[m].shrink_to_fit();
    StaticVisibilityView v = view(m);
    v.build = true;
    renderFrameInto(scene, textures[m], buildOptions, v, &scratch);
    stats_.pixels += static_cast<long>(pixels);
    stats_.bytes += records_[m].capacity() * sizeof(StaticHit);
  }
  builtDynamic_ = dynamic_;
  builtLights_ = scene.lights();
  built_ = true;
  ++stats_.builds;
  stats_.lastBuildMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  stats_.buildMs += stats_.lastBuildMs;
}

StaticVisibilityView FrameCache::view(std::size_t module) {
  StaticVisibilityView v;
  v.hits = records_[module].data();
  v.meshOfStatic = meshOfStatic_.data();
  v.triangleBase = triangleBase_.data();
  v.staticMeshes = meshOfStatic_.size();
  v.staticOfMesh = staticOfMesh_.data();
  v.lightsValid = lightsValid_;
  return v;
}

void FrameCache::dropRecords() {
  records_.clear();
  records_.shrink_to_fit();
  built_ = false;
  stats_.bytes = 0;
  stats_.pixels = 0;
}

void FrameCache::clear() {
  dropRecords();
  trial_ = false;
  stats_.declined = false;
}

}  // namespace parallax
