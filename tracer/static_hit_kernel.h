#pragma once
// The frame cache's side of a cached frame's primary rays, a SIMD vector of rays at a time
// (Google Highway, the widest instruction set the CPU has, chosen at run time).
//
// Before the trace (limitToStaticHits): each ray's cached static hit (static_visibility.h) is
// turned back into a point (the triangle's corners interpolated as hitInfoOf does) and its
// distance along the ray; the ray is then traced against the dynamic objects only as far as
// that point, or not at all (its lane parked: tnear > tfar) where it passes every dynamic
// object's bounding sphere (PhysicalScene::dynamicSpheres) before it. After the trace
// (takeStaticHits): the parked lanes get their distance back, and where the dynamic objects
// gave no nearer hit the static one is written into the packet as Embree would have.
//
// The arithmetic is the scalar formulas' in Eigen's order, without fused multiply-adds, so the
// distances, the parked lanes and the frames are bit-identical whichever target runs.

#include <embree3/rtcore.h>

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tracer/physical_scene.h"
#include "tracer/static_visibility.h"

namespace parallax {

// Per primary ray, what the cache gave it between the two steps (structure of arrays, sized
// for whole 16-ray packets; kept from tile to tile).
struct CachedHits {
  std::vector<std::int32_t> mesh;  // the static hit's mesh index, -1: the ray meets none
  std::vector<std::int32_t> prim;
  std::vector<float> t, u, v;        // its distance along the ray, its barycentrics
  std::vector<std::int32_t> lights;  // its StaticHit::lights()
  std::vector<std::int32_t> parked;  // -1: the ray passes every dynamic bound (not traced)

  void reserve(size_t rays) {
    const size_t n = (rays + 15) / 16 * 16;
    if (mesh.size() >= n) return;
    for (auto* a : {&mesh, &prim, &lights, &parked}) a->resize(n);
    for (auto* a : {&t, &u, &v}) a->resize(n);
  }
};

struct StaticHitJob {
  const StaticVisibilityView* view = nullptr;
  const PhysicalMesh* meshes = nullptr;      // the frame's PhysicalScene::meshes()
  const Eigen::Vector4f* spheres = nullptr;  // centre and radius, sphereCount of them
  std::size_t sphereCount = 0;
  const int* pixels = nullptr;  // per ray, its frame pixel (whole packets readable)
  RTCRayHit16* packets = nullptr;
  std::size_t rays = 0;
  CachedHits* hits = nullptr;  // reserved for `rays`
};

// Before the first generation's trace.
void limitToStaticHits(const StaticHitJob& job);

// After it: returns the rays that were parked; `*reused`, the static hits taken. `lights`: per
// ray, the static hit's light answers where it was taken, else 0.
long takeStaticHits(const StaticHitJob& job, std::uint8_t* lights, long* reused);

}  // namespace parallax
