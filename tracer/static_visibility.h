#pragma once
// What the frame cache (frame_cache.h) keeps of a module between frames: per pixel, where the
// primary ray meets the static geometry (the instances no update moves) and which static
// lights reach that point past the static geometry, in 12 bytes. The integrator reads it
// (StaticVisibilityView) to trace a frame's primary rays against the dynamic instances only,
// and writes it in one pass over a module at the cache's build.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace parallax {

// One pixel. u, v are Embree's barycentrics of the hit, kept as they came (a full re-trace
// of the same ray gives the same bits); the distance along the ray is recomputed from them
// (a few ulps from Embree's, which only the texture footprint sees).
struct StaticHit {
  // Low 24 bits of `packed`: the triangle, numbered over the static meshes in order
  // (StaticVisibilityView::triangleBase); kNoTriangle: the ray meets no static geometry.
  static constexpr std::uint32_t kNoTriangle = 0xFFFFFFu;
  static constexpr std::uint32_t kMaxTriangles = kNoTriangle;
  // High 8 bits: bit 7 says bits 0..6 hold the answer for static lights 0..6 (the scene's
  // first seven lights): 1, the light reaches the hit past every static surface. Bit 7 is clear
  // where a static surface is not a diffuse one (no shadow rays) or a shadow ray crossed static
  // glass (its transmittance is not a bit): those are traced every frame.
  static constexpr int kCachedLights = 7;
  static constexpr std::uint8_t kLightsKnown = 0x80u;

  float u = 0.0f;
  float v = 0.0f;
  std::uint32_t packed = kNoTriangle;

  std::uint32_t triangle() const { return packed & kNoTriangle; }
  std::uint8_t lights() const { return static_cast<std::uint8_t>(packed >> 24); }
  void setTriangle(std::uint32_t t) { packed = (packed & ~kNoTriangle) | (t & kNoTriangle); }
  void setLights(std::uint8_t bits) {
    packed = (packed & kNoTriangle) | (static_cast<std::uint32_t>(bits) << 24);
  }
};
static_assert(sizeof(StaticHit) == 12, "the cache's memory is quoted per pixel");

// How the integrator sees one module's cache in one frame.
struct StaticVisibilityView {
  // width × height records of the module (written when `build`).
  StaticHit* hits = nullptr;
  bool build = false;  // fill `hits` (trace against the static scene) instead of reading them
  // Per static mesh (in the cache's order): its mesh index in this frame's PhysicalScene and
  // the number of its first triangle; triangleBase has one more entry, the total.
  const int* meshOfStatic = nullptr;
  const std::uint32_t* triangleBase = nullptr;
  std::size_t staticMeshes = 0;
  // Build: per mesh index of the PhysicalScene, its static ordinal (-1: dynamic).
  const int* staticOfMesh = nullptr;
  // Bit k: static light k is where it was at the build (its bits hold). Lights that moved are
  // traced as before, against everything.
  std::uint8_t lightsValid = 0;
};

// What the cache did in a frame (summed over modules).
struct FrameCacheCounters {
  long pixelsReused = 0;          // primary hits taken from the cache (no static traversal)
  long primaryDynamicOnly = 0;    // primary rays traced against the dynamic instances only
  long primaryPassedDynamic = 0;  // of those, not traced: they pass every dynamic bound
  long shadowAnswered = 0;        // shadow rays not traced: a static surface blocks them
  long shadowPassedDynamic = 0;   // shadow rays not traced: they pass every dynamic bound
  long shadowDynamicOnly = 0;     // shadow rays traced against the dynamic instances only
  FrameCacheCounters& operator+=(const FrameCacheCounters& o) {
    pixelsReused += o.pixelsReused;
    primaryDynamicOnly += o.primaryDynamicOnly;
    primaryPassedDynamic += o.primaryPassedDynamic;
    shadowAnswered += o.shadowAnswered;
    shadowPassedDynamic += o.shadowPassedDynamic;
    shadowDynamicOnly += o.shadowDynamicOnly;
    return *this;
  }
};

}  // namespace parallax
