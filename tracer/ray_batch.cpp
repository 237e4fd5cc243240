#include "tracer/ray_batch.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

namespace parallax {
namespace {

// AOS → SOA for one group of up to 16 rays; lanes past `count` are invalid.
void toPacket(const RTCRay* rays, int count, RTCRay16* packet, int* valid) {
  for (int i = 0; i < 16; ++i) {
    const RTCRay& r = rays[std::min(i, count - 1)];
    valid[i] = i < count ? -1 : 0;
    packet->org_x[i] = r.org_x;
    packet->org_y[i] = r.org_y;
    packet->org_z[i] = r.org_z;
    packet->tnear[i] = r.tnear;
    packet->dir_x[i] = r.dir_x;
    packet->dir_y[i] = r.dir_y;
    packet->dir_z[i] = r.dir_z;
    packet->time[i] = r.time;
    packet->tfar[i] = r.tfar;
    packet->mask[i] = r.mask;
    packet->id[i] = r.id;
    packet->flags[i] = r.flags;
  }
}

}  // namespace

RTCIntersectContext intersectContext(bool coherent) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags =
      coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  return context;
}

const char* traversalName(Traversal traversal) {
  switch (traversal) {
    case Traversal::kSingle:
      return "single";
    case Traversal::kPacket16:
      return "packet16";
    case Traversal::kStream:
      return "stream";
  }
  return "?";
}

bool parseTraversal(const char* name, Traversal* traversal) {
  for (Traversal t : {Traversal::kSingle, Traversal::kPacket16, Traversal::kStream}) {
    if (std::strcmp(name, traversalName(t)) == 0) {
      *traversal = t;
      return true;
    }
  }
  return false;
}

void intersectBatch(RTCScene scene, std::span<RTCRayHit> rays, Traversal traversal, bool coherent) {
  if (rays.empty()) return;
  RTCIntersectContext context = intersectContext(coherent);
  switch (traversal) {
    case Traversal::kSingle:
      for (RTCRayHit& r : rays) rtcIntersect1(scene, &context, &r);
      break;
    case Traversal::kStream:
      rtcIntersect1M(scene, &context, rays.data(), static_cast<unsigned>(rays.size()),
                     sizeof(RTCRayHit));
      break;
    case Traversal::kPacket16: {
      alignas(64) RTCRayHit16 packet;
      alignas(64) int valid[16];
      for (size_t start = 0; start < rays.size(); start += 16) {
        const int count = static_cast<int>(std::min<size_t>(16, rays.size() - start));
        // Gather only the ray half; the hit half is initialised as invalid.
        RTCRay group[16];
        for (int i = 0; i < count; ++i) group[i] = rays[start + static_cast<size_t>(i)].ray;
        toPacket(group, count, &packet.ray, valid);
        for (int i = 0; i < 16; ++i) {
          packet.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
          packet.hit.primID[i] = RTC_INVALID_GEOMETRY_ID;
          packet.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
          packet.hit.u[i] = packet.hit.v[i] = 0.0f;
          packet.hit.Ng_x[i] = packet.hit.Ng_y[i] = packet.hit.Ng_z[i] = 0.0f;
        }
        rtcIntersect16(valid, scene, &context, &packet);
        for (int i = 0; i < count; ++i) {
          RTCRayHit& r = rays[start + static_cast<size_t>(i)];
          r.ray.tfar = packet.ray.tfar[i];
          r.hit.geomID = packet.hit.geomID[i];
          r.hit.primID = packet.hit.primID[i];
          r.hit.instID[0] = packet.hit.instID[0][i];
          r.hit.u = packet.hit.u[i];
          r.hit.v = packet.hit.v[i];
          r.hit.Ng_x = packet.hit.Ng_x[i];
          r.hit.Ng_y = packet.hit.Ng_y[i];
          r.hit.Ng_z = packet.hit.Ng_z[i];
        }
      }
      break;
    }
  }
}

}  // namespace parallax
