#pragma once
// Every lit surface's shadow ray toward one light, a SIMD vector of surfaces at a time (Google
// Highway, the widest instruction set the CPU has, chosen at run time): the light's direction
// and distance, the Lambert and Phong response, and which rays are kept, compress-stored into
// StagedRays. The arithmetic is the scalar integrator's, operation for operation and without
// fused multiply-adds, so the frames are bit-identical whichever target runs.
//
// A ray is kept when the light reaches the surface's front (and, unless building the frame
// cache, adds something). With the frame cache (`cachedBit`: this static light's bit, 0 when
// the cache does not answer for it), a surface whose static answers are known gets no ray when
// a static surface blocks the light (counted in `answered`), and a ray against the dynamic
// objects only (`dynamic`) when none does, unless that ray passes every dynamic object's
// bounding sphere (PhysicalScene::dynamicSpheres): then nothing can block it and its light goes
// to `unblocked`, for addLight, without a trip through Embree.
//
// With `occluders` (PhysicalScene::occluders, a first generation's rays: one a pixel toward the
// light, so the order their light is added in does not matter), a ray that would go to Embree
// goes to `unblocked` instead when it passes every mesh's bound: nothing can block it. A ray
// that leaves a bare face of its own mesh (LitSurfaces::kLeavesMesh, PhysicalMesh::bareFaces)
// cannot meet that mesh, and skips its bound. With `parkPassing` (a later generation's rays: a
// pixel may have two toward one light, whose light must be added in ray order) such a ray stays
// in `rays`, in its place, parked: tfar kParkedTfar, below tnear 0, so Embree skips it, and
// OcclusionPackets::occluded reads it as clear.

#include <embree3/rtcore.h>

#include <cstddef>
#include <cstdint>

#include "tracer/lit_surfaces.h"
#include "tracer/physical_scene.h"
#include "tracer/shadow_block_cull.h"
#include "tracer/staged_rays.h"

namespace parallax {

struct ShadowRayJob {
  const LitSurfaces* surfaces = nullptr;
  const PhysicalLight* light = nullptr;
  float worldPerPhysical = 1.0f;
  bool build = false;  // filling the frame cache: every ray the light's direction allows
  std::uint8_t cachedBit = 0;
  StagedRays* rays = nullptr;                // reserved for surfaces->size() rays
  StagedRays* dynamic = nullptr;             // likewise, when cachedBit != 0
  StagedRays* unblocked = nullptr;           // likewise (pixels and kR, kG, kB only)
  const Eigen::Vector4f* spheres = nullptr;  // centre and radius, sphereCount of them
  std::size_t sphereCount = 0;
  const OccluderBound* occluders = nullptr;  // occluderCount of them; null: no test
  std::size_t occluderCount = 0;
  bool parkPassing = false;  // rays that pass every bound stay in `rays`, parked
  // Where the surfaces lie (spreadOf): a directional light's rays are tested only against the
  // occluders they may meet from there. Null: against every one.
  const SurfaceSpread* spread = nullptr;
};

// A parked shadow ray's tfar: below its tnear of 0, so Embree leaves it (and its tfar) alone;
// finite, so it is not the −∞ of a blocked ray.
inline constexpr float kParkedTfar = -1.0f;

struct ShadowRayCounts {
  long answered = 0;         // the frame cache answered them: blocked by a static surface
  long passedDynamic = 0;    // the cache's clear rays that pass every dynamic bound
  long passedOccluders = 0;  // rays that pass every mesh's bound (`occluders`)
  long blockedByCores = 0;   // rays through a mesh's core (OccluderBound::core): blocked
};

// Makes the rays (job.rays, and with the cache job.dynamic) and lists the light that needs no
// ray in job.unblocked.
ShadowRayCounts makeShadowRays(const ShadowRayJob& job);

// After Embree traced them (`packets`: the staged rays in order, tfar −inf where blocked), adds
// each unblocked ray's contribution (kR, kG, kB) to its pixel, a vector of rays at a time: a
// run of lanes that light consecutive pixels (up to three runs a vector: a row of the tile, the
// next row) reads and writes their colours as whole vectors, the other lanes' colours are
// gathered, added to and scattered back. The rays' pixels must differ (a first generation's
// rays toward one light: one a pixel), so a vector's lanes never write the same pixel; each
// colour gets exactly the scalar `+=`, so the frame is bit-identical.
void addUnblockedLight(const StagedRays& staged, const RTCRay16* packets, Rgb* pixels);
// The same for rays nothing blocks (ShadowRayJob::unblocked): every one adds its light.
void addLight(const StagedRays& staged, Rgb* pixels);

}  // namespace parallax
