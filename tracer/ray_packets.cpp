#include "tracer/ray_packets.h"

#include <algorithm>
#include <cstring>
#include <limits>

#include "tracer/glass_shadows.h"

namespace parallax {
namespace {

// valid[] of packet p: all lanes but those past the last ray.
void validLanes(size_t packet, size_t size, int* valid) {
  for (size_t lane = 0; lane < 16; ++lane) valid[lane] = packet * 16 + lane < size ? -1 : 0;
}

// The one loop behind both queries: ray by ray, packet by packet (the last packet's unused
// lanes masked off) or as one stream (unused lanes made empty, tnear > tfar). `lanes` gives a
// packet's ray part (RTCRay16 of an RTCRayHit16, or the RTCRay16 itself).
template <class Packets, class One, class Sixteen, class Stream, class Lanes>
void traceBatch(Packets& rays, Traversal traversal, One traceOne, Sixteen traceSixteen,
                Stream traceStream, Lanes lanes) {
  if (rays.empty()) return;
  const size_t count = rays.packetCount();
  switch (traversal) {
    case Traversal::kSingle:
      for (size_t i = 0; i < rays.size(); ++i) {
        auto r = rays.get(i);
        traceOne(&r);
        rays.set(i, r);
      }
      break;
    case Traversal::kPacket16: {
      alignas(64) int valid[16];
      validLanes(0, 16, valid);
      for (size_t p = 0; p < count; ++p) {
        if (p + 1 == count) validLanes(p, rays.size(), valid);
        traceSixteen(valid, &rays.packets()[p]);
      }
      break;
    }
    case Traversal::kStream: {
      RTCRay16& last = lanes(rays.packets()[count - 1]);
      for (size_t lane = rays.size() % 16; lane != 0 && lane < 16; ++lane) {
        last.tnear[lane] = 1.0f;
        last.tfar[lane] = 0.0f;
      }
      traceStream(rays.packets(), static_cast<unsigned>(count));
      break;
    }
  }
}

// Packet p's origin and direction from `staged` (which pads each field, so the last packet's 16
// floats can be read whole), tnear 0.
void copyStagedRays(const StagedRays& staged, size_t p, RTCRay16* q) {
  const size_t first = 16 * p;
  const auto copy16 = [&](float* to, StagedRays::Field f) {
    std::memcpy(to, staged.field(f) + first, 16 * sizeof(float));
  };
  copy16(q->org_x, StagedRays::kOx);
  copy16(q->org_y, StagedRays::kOy);
  copy16(q->org_z, StagedRays::kOz);
  copy16(q->dir_x, StagedRays::kDx);
  copy16(q->dir_y, StagedRays::kDy);
  copy16(q->dir_z, StagedRays::kDz);
  std::fill(q->tnear, q->tnear + 16, 0.0f);
}

}  // namespace

void RayHitPackets::grow() {
  RTCRayHit16& p = packets_.emplace_back();
  for (size_t lane = 0; lane < 16; ++lane) {
    p.ray.time[lane] = 0.0f;
    p.ray.mask[lane] = 0xFFFFFFFFu;
    p.ray.id[lane] = 0;
    p.ray.flags[lane] = 0;
    p.hit.primID[lane] = RTC_INVALID_GEOMETRY_ID;
    p.hit.instID[0][lane] = RTC_INVALID_GEOMETRY_ID;  // scenes are flattened: Embree never sets it
  }
}

void OcclusionPackets::grow() {
  const auto first = static_cast<unsigned>(16 * packets_.size());
  RTCRay16& p = packets_.emplace_back();
  for (unsigned lane = 0; lane < 16; ++lane) {
    p.time[lane] = 0.0f;
    p.mask[lane] = 0xFFFFFFFFu;
    p.id[lane] = first + lane;
    p.flags[lane] = 0;
  }
}

void RayHitPackets::assign(const StagedRays& staged) {
  const size_t n = staged.size();
  while (16 * packets_.size() < n) grow();
  for (size_t p = 0; 16 * p < n; ++p) {
    RTCRayHit16& q = packets_[p];
    copyStagedRays(staged, p, &q.ray);
    std::fill(q.ray.tfar, q.ray.tfar + 16, std::numeric_limits<float>::infinity());
    // Embree writes the hit record only on a hit; this marks a miss.
    std::fill(q.hit.geomID, q.hit.geomID + 16, RTC_INVALID_GEOMETRY_ID);
  }
  size_ = n;
}

void OcclusionPackets::assign(const StagedRays& staged) {
  const size_t n = staged.size();
  reserveRays(n);
  for (size_t p = 0; 16 * p < n; ++p) {
    copyStagedRays(staged, p, &packets_[p]);
    std::memcpy(packets_[p].tfar, staged.field(StagedRays::kTfar) + 16 * p, 16 * sizeof(float));
  }
  size_ = n;
}

RTCRayHit RayHitPackets::get(size_t i) const {
  const RTCRayHit16& p = packets_[i / 16];
  const size_t l = i % 16;
  RTCRayHit r;
  r.ray.org_x = p.ray.org_x[l];
  r.ray.org_y = p.ray.org_y[l];
  r.ray.org_z = p.ray.org_z[l];
  r.ray.tnear = p.ray.tnear[l];
  r.ray.dir_x = p.ray.dir_x[l];
  r.ray.dir_y = p.ray.dir_y[l];
  r.ray.dir_z = p.ray.dir_z[l];
  r.ray.time = p.ray.time[l];
  r.ray.tfar = p.ray.tfar[l];
  r.ray.mask = p.ray.mask[l];
  r.ray.id = p.ray.id[l];
  r.ray.flags = p.ray.flags[l];
  r.hit.Ng_x = p.hit.Ng_x[l];
  r.hit.Ng_y = p.hit.Ng_y[l];
  r.hit.Ng_z = p.hit.Ng_z[l];
  r.hit.u = p.hit.u[l];
  r.hit.v = p.hit.v[l];
  r.hit.primID = p.hit.primID[l];
  r.hit.geomID = p.hit.geomID[l];
  r.hit.instID[0] = p.hit.instID[0][l];
  return r;
}

void RayHitPackets::set(size_t i, const RTCRayHit& r) {
  RTCRayHit16& p = packets_[i / 16];
  const size_t l = i % 16;
  p.ray.tfar[l] = r.ray.tfar;
  p.hit.Ng_x[l] = r.hit.Ng_x;
  p.hit.Ng_y[l] = r.hit.Ng_y;
  p.hit.Ng_z[l] = r.hit.Ng_z;
  p.hit.u[l] = r.hit.u;
  p.hit.v[l] = r.hit.v;
  p.hit.primID[l] = r.hit.primID;
  p.hit.geomID[l] = r.hit.geomID;
  p.hit.instID[0][l] = r.hit.instID[0];
}

RTCRay OcclusionPackets::get(size_t i) const {
  const RTCRay16& p = packets_[i / 16];
  const size_t l = i % 16;
  RTCRay r;
  r.org_x = p.org_x[l];
  r.org_y = p.org_y[l];
  r.org_z = p.org_z[l];
  r.tnear = p.tnear[l];
  r.dir_x = p.dir_x[l];
  r.dir_y = p.dir_y[l];
  r.dir_z = p.dir_z[l];
  r.time = p.time[l];
  r.tfar = p.tfar[l];
  r.mask = p.mask[l];
  r.id = p.id[l];
  r.flags = p.flags[l];
  return r;
}

void OcclusionPackets::set(size_t i, const RTCRay& r) { packets_[i / 16].tfar[i % 16] = r.tfar; }

void intersectPackets(RTCScene scene, RayHitPackets& rays, Traversal traversal, bool coherent) {
  RTCIntersectContext context = intersectContext(coherent);
  traceBatch(
      rays, traversal, [&](RTCRayHit* r) { rtcIntersect1(scene, &context, r); },
      [&](const int* valid, RTCRayHit16* p) { rtcIntersect16(valid, scene, &context, p); },
      [&](RTCRayHit16* packets, unsigned count) {
        rtcIntersectNM(scene, &context, reinterpret_cast<RTCRayHitN*>(packets), 16, count,
                       sizeof(RTCRayHit16));
      },
      [](RTCRayHit16& p) -> RTCRay16& { return p.ray; });
}

void intersectPackets(const RTCScene* scenes, RayHitPackets& rays, Traversal traversal,
                      bool coherent) {
  RTCIntersectContext context = intersectContext(coherent);
  if (traversal == Traversal::kSingle) {
    for (size_t i = 0; i < rays.size(); ++i) {
      RTCRayHit r = rays.get(i);
      rtcIntersect1(scenes[i], &context, &r);
      rays.set(i, r);
    }
    return;
  }
  alignas(64) int valid[16];
  for (size_t p = 0; p < rays.packetCount(); ++p) {
    const RTCScene* lanes = scenes + 16 * p;
    const size_t count = std::min<size_t>(16, rays.size() - 16 * p);
    unsigned traced = 0;  // a bit per lane
    for (size_t lead = 0; lead < count; ++lead) {
      if (traced >> lead & 1u) continue;
      for (size_t lane = 0; lane < 16; ++lane) {
        const bool with = lane < count && lanes[lane] == lanes[lead];
        valid[lane] = with ? -1 : 0;
        if (with) traced |= 1u << lane;
      }
      rtcIntersect16(valid, lanes[lead], &context, &rays.packets()[p]);
    }
  }
}

void occludedPackets(RTCScene scene, OcclusionPackets& rays, Traversal traversal, bool coherent) {
  ShadowQueryContext query = shadowQueryContext(coherent);
  occludedPackets(scene, rays, traversal, &query);
}

void occludedPackets(RTCScene scene, OcclusionPackets& rays, Traversal traversal,
                     ShadowQueryContext* query) {
  RTCIntersectContext& context = query->base;
  traceBatch(
      rays, traversal, [&](RTCRay* r) { rtcOccluded1(scene, &context, r); },
      [&](const int* valid, RTCRay16* p) { rtcOccluded16(valid, scene, &context, p); },
      [&](RTCRay16* packets, unsigned count) {
        rtcOccludedNM(scene, &context, reinterpret_cast<RTCRayN*>(packets), 16, count,
                      sizeof(RTCRay16));
      },
      [](RTCRay16& p) -> RTCRay16& { return p; });
}

}  // namespace parallax
