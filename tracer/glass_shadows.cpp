#include "tracer/glass_shadows.h"

#include <cmath>

#include "common/check.h"
#include "tracer/optics.h"
#include "tracer/physical_scene.h"
#include "tracer/ray_batch.h"

namespace parallax {

ShadowQueryContext shadowQueryContext(bool coherent, const PhysicalScene* scene,
                                      ShadowTransmittance* transmittance, std::uint8_t* seen,
                                      long* filterCalls) {
  PARALLAX_CHECK((transmittance == nullptr) == (seen == nullptr));
  ShadowQueryContext context;
  context.base = intersectContext(coherent);
  context.scene = scene;
  context.transmittance = transmittance;
  context.seen = seen;
  context.filterCalls = filterCalls;
  return context;
}

void glassShadowFilter(const RTCFilterFunctionNArguments* args) {
  // Every occlusion query passes a ShadowQueryContext (ray_packets.cpp, ray_batch.cpp), whose
  // first member is the RTCIntersectContext Embree hands back here.
  const auto* context = reinterpret_cast<const ShadowQueryContext*>(args->context);
  if (!context->transmittance) return;  // glass as an opaque blocker: accept the hit
  const PhysicalScene& scene = *context->scene;
  const unsigned n = args->N;
  for (unsigned i = 0; i < n; ++i) {
    if (args->valid[i] == 0) continue;
    if (context->filterCalls) ++*context->filterCalls;
    const unsigned geomID = RTCHitN_geomID(args->hit, n, i);
    const unsigned primID = RTCHitN_primID(args->hit, n, i);
    const unsigned ray = RTCRayN_id(args->ray, n, i);
    ShadowTransmittance& state = context->transmittance[ray];
    if (!context->seen[ray]) {
      context->seen[ray] = 1;
      state.reset();
    }
    const std::uint64_t key = (static_cast<std::uint64_t>(geomID) << 32) | primID;
    bool seen = false;
    for (int k = 0; k < state.crossings; ++k) seen = seen || state.crossed[k] == key;
    if (seen) {
      args->valid[i] = 0;  // the same triangle again (spatial splits): already counted
      continue;
    }
    if (state.crossings == ShadowTransmittance::kMaxCrossings) continue;  // too much glass: blocked
    state.crossed[state.crossings++] = key;

    const PhysicalMesh& mesh = scene.meshes()[geomID];
    const Material& glass = scene.materials()[static_cast<size_t>(mesh.material)];
    const Eigen::Vector3f d(RTCRayN_dir_x(args->ray, n, i), RTCRayN_dir_y(args->ray, n, i),
                            RTCRayN_dir_z(args->ray, n, i));
    const float length = d.norm();
    const float facing = mesh.faceNormals[primID].dot(d) / length;  // < 0: entering (front face)
    // Air → glass at the straight ray's angle (see the header for why both crossings use it).
    const float cosI = std::min(1.0f, std::abs(facing));
    const float eta = 1.0f / glass.ior;
    const float sin2T = eta * eta * std::max(0.0f, 1.0f - cosI * cosI);
    const float cosT = std::sqrt(std::max(0.0f, 1.0f - sin2T));
    state.fresnel *= 1.0f - fresnelDielectric(cosI, cosT, eta);
    // Embree puts the hit's distance in tfar while the filter runs.
    const float worldT = RTCRayN_tfar(args->ray, n, i) * length * scene.worldPerPhysical();
    state.opticalDepth += (facing < 0.0f ? -worldT : worldT) * glass.absorption;
    // Keep going (reject the hit) unless the glass already lets through next to nothing.
    if (state.fresnel > 1e-6f) args->valid[i] = 0;
  }
}

}  // namespace parallax
