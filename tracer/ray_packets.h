#pragma once
// The integrator's ray arrays in the layout Embree traverses: 16-wide SoA packets (RTCRay16,
// RTCRayHit16), filled lane by lane as rays are generated. Tracing them as packets or as a
// stream of packets (rtcIntersectNM) then needs no AoS→SoA gather and no copy back, which an
// AoS array of RTCRayHit costs on every generation (Embree's own 1M stream path does that gather
// internally). The single-ray traversal is kept for comparison: it copies each lane out and back.

#include <embree3/rtcore.h>

#include <Eigen/Core>
#include <limits>
#include <vector>

#include "tracer/ray_batch.h"
#include "tracer/staged_rays.h"

namespace parallax {

struct ShadowQueryContext;

// Intersection rays with their hit records. clear() keeps the memory: a renderer reuses the
// same packets frame after frame.
class RayHitPackets {
 public:
  void clear() { size_ = 0; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

  // The fields no ray changes (time, mask, id, flags) were set when the packet was made, so a
  // push stores only what differs per ray.
  void push(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
            float tfar = std::numeric_limits<float>::infinity()) {
    if (size_ == 16 * packets_.size()) grow();
    const size_t lane = size_ % 16;
    RTCRayHit16& p = packets_[size_ / 16];
    p.ray.org_x[lane] = origin.x();
    p.ray.org_y[lane] = origin.y();
    p.ray.org_z[lane] = origin.z();
    p.ray.dir_x[lane] = direction.x();
    p.ray.dir_y[lane] = direction.y();
    p.ray.dir_z[lane] = direction.z();
    p.ray.tnear[lane] = 0.0f;  // the stream traversal parks unused lanes with tnear > tfar
    p.ray.tfar[lane] = tfar;
    // Embree writes the hit record only on a hit; this marks a miss.
    p.hit.geomID[lane] = RTC_INVALID_GEOMETRY_ID;
    ++size_;
  }

  // Exactly the rays of `staged` (origin, direction; tfar infinite, no hit yet), a 64-byte copy
  // per field and packet.
  void assign(const StagedRays& staged);

  // Lane i (in push order).
  unsigned geomID(size_t i) const { return packets_[i / 16].hit.geomID[i % 16]; }
  unsigned primID(size_t i) const { return packets_[i / 16].hit.primID[i % 16]; }
  float u(size_t i) const { return packets_[i / 16].hit.u[i % 16]; }
  float v(size_t i) const { return packets_[i / 16].hit.v[i % 16]; }
  float tfar(size_t i) const { return packets_[i / 16].ray.tfar[i % 16]; }
  Eigen::Vector3f direction(size_t i) const {
    const RTCRay16& r = packets_[i / 16].ray;
    return {r.dir_x[i % 16], r.dir_y[i % 16], r.dir_z[i % 16]};
  }
  Eigen::Vector3f origin(size_t i) const {
    const RTCRay16& r = packets_[i / 16].ray;
    return {r.org_x[i % 16], r.org_y[i % 16], r.org_z[i % 16]};
  }
  // The frame cache: a ray traced only as far as its cached hit, and that hit written in when
  // nothing nearer was found.
  void setTfar(size_t i, float tfar) { packets_[i / 16].ray.tfar[i % 16] = tfar; }
  // A lane left out of the next trace (tnear > tfar: Embree skips it), then given back its
  // tnear of 0 and `tfar`.
  void park(size_t i) {
    packets_[i / 16].ray.tnear[i % 16] = 1.0f;
    packets_[i / 16].ray.tfar[i % 16] = 0.0f;
  }
  void unpark(size_t i, float tfar) {
    packets_[i / 16].ray.tnear[i % 16] = 0.0f;
    packets_[i / 16].ray.tfar[i % 16] = tfar;
  }
  void setHit(size_t i, unsigned geomID, unsigned primID, float u, float v) {
    RTCHit16& h = packets_[i / 16].hit;
    h.geomID[i % 16] = geomID;
    h.primID[i % 16] = primID;
    h.u[i % 16] = u;
    h.v[i % 16] = v;
  }
  // Lane i as a single ray (logging, the single-ray traversal).
  RTCRayHit get(size_t i) const;
  void set(size_t i, const RTCRayHit& r);

  size_t packetCount() const { return (size_ + 15) / 16; }
  RTCRayHit16* packets() { return packets_.data(); }

 private:
  void grow();  // one more packet (out of line: push stays small enough to inline)
  std::vector<RTCRayHit16> packets_;
  size_t size_ = 0;
};

// Occlusion rays (shadow rays): after tracing, occluded(i) tells whether something blocks ray i.
class OcclusionPackets {
 public:
  void clear() { size_ = 0; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

  void push(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float tfar) {
    if (size_ == 16 * packets_.size()) grow();
    write(size_, origin, direction, tfar);
    ++size_;
  }

  // Branch-free filling: make room for n rays, write() any slot below n (a slot may be written
  // again), then setSize() to the number kept. The fields no ray changes (time, mask, flags)
  // and a slot's id (its index: the glass filter's index into its states) were set when the
  // packet was made, so a write stores only what differs per ray.
  void reserveRays(size_t n) {
    while (16 * packets_.size() < n) grow();
  }
  void write(size_t slot, const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
             float tfar) {
    const size_t lane = slot % 16;
    RTCRay16& p = packets_[slot / 16];
    p.org_x[lane] = origin.x();
    p.org_y[lane] = origin.y();
    p.org_z[lane] = origin.z();
    p.dir_x[lane] = direction.x();
    p.dir_y[lane] = direction.y();
    p.dir_z[lane] = direction.z();
    p.tnear[lane] = 0.0f;
    p.tfar[lane] = tfar;
  }
  void setSize(size_t n) { size_ = n; }
  // Exactly the rays of `staged` (origin, direction, tfar), a 64-byte copy per field and packet.
  void assign(const StagedRays& staged);

  // Embree sets tfar to -inf on an occluded ray (a parked one, tfar below tnear, it skips).
  bool occluded(size_t i) const {
    return packets_[i / 16].tfar[i % 16] == -std::numeric_limits<float>::infinity();
  }
  RTCRay get(size_t i) const;
  void set(size_t i, const RTCRay& r);

  size_t packetCount() const { return (size_ + 15) / 16; }
  RTCRay16* packets() { return packets_.data(); }
  const RTCRay16* packets() const { return packets_.data(); }

 private:
  void grow();
  std::vector<RTCRay16> packets_;
  size_t size_ = 0;
};

// Trace every ray with the traversal: kPacket16 one rtcIntersect16 per packet (the partial last
// one masked), kStream one rtcIntersectNM over all packets (the unused lanes of the last packet
// made inactive, tnear > tfar), kSingle one rtcIntersect1 per ray.
void intersectPackets(RTCScene scene, RayHitPackets& rays, Traversal traversal, bool coherent);
// Ray i against scenes[i]: kSingle one rtcIntersect1 per ray; kPacket16 and kStream one
// rtcIntersect16 per packet and scene its lanes name, the other lanes masked off.
void intersectPackets(const RTCScene* scenes, RayHitPackets& rays, Traversal traversal,
                      bool coherent);
// Glass blocks these (no transmittance states).
void occludedPackets(RTCScene scene, OcclusionPackets& rays, Traversal traversal, bool coherent);
// With the caller's context: its transmittance states (if any) are indexed by push order.
void occludedPackets(RTCScene scene, OcclusionPackets& rays, Traversal traversal,
                     ShadowQueryContext* query);

}  // namespace parallax
