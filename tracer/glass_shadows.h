#pragma once
// Shadow rays through glass. A dielectric does not block a shadow ray: it lets through its
// Fresnel transmittance at each surface the ray crosses and, per colour channel, the
// Beer–Lambert factor exp(−absorption · chord) over the length of the ray inside it.
//
// Approximation (documented in the README): the shadow ray is not refracted. It runs straight
// to the light, and each crossing uses the unpolarised Fresnel transmittance of air → glass at
// the angle between that straight ray and the surface. For a parallel-sided slab this is exact
// for the Fresnel part (by reciprocity the glass → air exit at the refracted angle transmits
// the same as the air → glass entry, and a refracted ray leaves a slab parallel to how it came
// in); the chord is the straight one, not the refracted path (equal at normal incidence).
// Caustics, focusing and total internal reflection are not modelled for shadow rays.
//
// How: an Embree occlusion filter on the dielectric geometries (set by PhysicalScene). It
// rejects each glass hit — so traversal goes on to any opaque blocker — after folding it into
// the ray's ShadowTransmittance. Hits arrive in any order and, with the high-quality
// (spatial-split) BVH, possibly more than once for the same triangle: the state remembers the
// triangles it counted, and the chord is accumulated order-free as Σ ±absorption·t (exits add
// their distance, entries subtract theirs). Scenes without glass never call it.

#include <embree3/rtcore.h>

#include <cstddef>
#include <cstdint>

#include "tracer/scene.h"

namespace parallax {

class PhysicalScene;

// Per shadow ray: what the glass it crossed lets through so far.
struct ShadowTransmittance {
  // A ray that crosses more glass surfaces than this is treated as blocked (conservative; the
  // fixtures cross at most 4).
  static constexpr int kMaxCrossings = 8;
  float fresnel = 1.0f;            // product of the crossings' Fresnel transmittances
  Rgb opticalDepth = Rgb::Zero();  // Σ over exits of absorption·t − Σ over entries (world units)
  int crossings = 0;
  std::uint64_t crossed[kMaxCrossings];  // (geomID << 32 | primID) of the triangles counted

  // The fraction of light that gets through, per channel (after an unoccluded query). A ray that
  // enters glass and ends inside it (a light inside glass, an open mesh) keeps no absorption.
  Rgb factor() const { return fresnel * (-opticalDepth.cwiseMax(0.0f)).array().exp().matrix(); }

  // Ready for a new ray: only the running fields (`crossed` is read below `crossings` only). The
  // filter does it when it first meets the ray (ShadowQueryContext::seen).
  void reset() {
    fresnel = 1.0f;
    opticalDepth.setZero();
    crossings = 0;
  }
};

// The context every occlusion query on a PhysicalScene passes to Embree (base first: Embree
// sees only that). With `transmittance` null, glass blocks like any surface (one state per ray
// otherwise, indexed by the ray's id, with a `seen` flag per ray that the caller zeroes: the
// filter resets a ray's state when it first meets the ray, so most rays, which cross no glass,
// cost a byte instead of a state's reset, and the caller finds the rays that crossed glass by
// their flag).
struct ShadowQueryContext {
  RTCIntersectContext base;
  const PhysicalScene* scene = nullptr;
  ShadowTransmittance* transmittance = nullptr;
  std::uint8_t* seen = nullptr;  // with transmittance: per ray, 1 once the filter met it
  long* filterCalls = nullptr;   // optional: glass hits the filter saw (duplicates included)
};

// `coherent`: the RTCIntersectContext flag (see intersectContext in ray_batch.h).
ShadowQueryContext shadowQueryContext(bool coherent, const PhysicalScene* scene = nullptr,
                                      ShadowTransmittance* transmittance = nullptr,
                                      std::uint8_t* seen = nullptr, long* filterCalls = nullptr);

// Whether ray i of a query crossed glass (its state then holds what the glass let through).
inline bool crossedGlass(const ShadowTransmittance* transmittance, const std::uint8_t* seen,
                         size_t i) {
  return seen[i] != 0 && transmittance[i].crossings > 0;
}

// The occlusion filter PhysicalScene sets on dielectric geometries.
void glassShadowFilter(const RTCFilterFunctionNArguments* args);

}  // namespace parallax
