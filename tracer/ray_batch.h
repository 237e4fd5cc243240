#pragma once
// Tracing a batch of rays through Embree with one of three traversals, and the robust origin
// offset that keeps secondary rays from hitting the surface they leave.
//
// The integrator works wavefront-style per tile: it gathers all rays of one kind (primary,
// shadow, next bounce) into an array and traces the array at once, so the same code can hand
// the array to Embree one ray at a time, as 16-wide packets or as a stream. The bench measures
// all three (`parallax bench tracer`); the default is the one it chose.

#include <embree3/rtcore.h>

#include <Eigen/Core>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

namespace parallax {

enum class Traversal : std::uint8_t {
  kSingle,    // rtcIntersect1 / rtcOccluded1 per ray
  kPacket16,  // rtcIntersect16 / rtcOccluded16 on consecutive groups of 16
  kStream,    // rtcIntersect1M / rtcOccluded1M over the whole array
};

const char* traversalName(Traversal traversal);
// Returns false for an unknown name ("single", "packet16", "stream").
bool parseTraversal(const char* name, Traversal* traversal);

// Fully initialised ray (Embree's tutorials insist: every field set, hit ids invalid).
inline RTCRayHit makeRayHit(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                            float tfar = std::numeric_limits<float>::infinity()) {
  RTCRayHit r;
  r.ray.org_x = origin.x();
  r.ray.org_y = origin.y();
  r.ray.org_z = origin.z();
  r.ray.tnear = 0.0f;
  r.ray.dir_x = direction.x();
  r.ray.dir_y = direction.y();
  r.ray.dir_z = direction.z();
  r.ray.time = 0.0f;
  r.ray.tfar = tfar;
  r.ray.mask = 0xFFFFFFFFu;
  r.ray.id = 0;
  r.ray.flags = 0;
  r.hit.Ng_x = r.hit.Ng_y = r.hit.Ng_z = 0.0f;
  r.hit.u = r.hit.v = 0.0f;
  r.hit.primID = RTC_INVALID_GEOMETRY_ID;
  r.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  r.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return r;
}

// The context of one batch: coherent (primary rays and their shadow rays) or incoherent.
RTCIntersectContext intersectContext(bool coherent);

void intersectBatch(RTCScene scene, std::span<RTCRayHit> rays, Traversal traversal, bool coherent);

// Moves a hit point p off its surface along the unit geometric normal n (pointing to the side
// the new ray leaves from) by an amount that scales with |p|: a few float ulps of each
// coordinate (integer steps on the bit pattern), and a small absolute step near the origin
// where ulps vanish. No fixed epsilon, so it works the same for any coordinate magnitude.
// The hit point should be computed from the triangle's vertices (barycentric), not o + t·d, so
// its own error is ulps of the vertices rather than of the ray length.
// Inline: it runs at every hit.
inline Eigen::Vector3f offsetRayOrigin(const Eigen::Vector3f& p, const Eigen::Vector3f& n) {
  // Within kNearOrigin of 0 a coordinate's ulp is tiny, so a fixed small step is used there;
  // elsewhere kUlpSteps·|n_i| ulps of the coordinate itself. The constants follow Wächter and
  // Binder ("A fast and robust method for avoiding self-intersection", Ray Tracing Gems, 2019),
  // sized for coordinates of order 1 (physical space is always about a metre across).
  constexpr float kNearOrigin = 1.0f / 32.0f;
  constexpr float kNearStep = 1.0f / 65536.0f;
  constexpr float kUlpSteps = 256.0f;
  Eigen::Vector3f out;
  for (int i = 0; i < 3; ++i) {
    const int steps = static_cast<int>(kUlpSteps * n[i]);
    const std::int32_t bits = std::bit_cast<std::int32_t>(p[i]);
    const float moved = std::bit_cast<float>(bits + (p[i] < 0.0f ? -steps : steps));
    out[i] = std::abs(p[i]) < kNearOrigin ? p[i] + kNearStep * n[i] : moved;
  }
  return out;
}

}  // namespace parallax
