// Compiled once per instruction set by Highway's foreach_target (HWY_TARGET_INCLUDE): the code in
// HWY_NAMESPACE is each target's; the dispatch at the end runs the best the CPU supports.
// SSSE3 without SSE4 is left out (CPUs before 2008): one compile less.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tracer/shadow_ray_kernel.cpp"
#include "tracer/shadow_ray_kernel.h"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "tracer/shadow_block_cull.h"
#include "tracer/simd_math-inl.h"
#include "tracer/static_visibility.h"

HWY_BEFORE_NAMESPACE();
namespace parallax {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <bool kPoint>
ShadowRayCounts MakeShadowRaysFor(const ShadowRayJob& job) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  const size_t lanes = hn::Lanes(d);
  const LitSurfaces& s = *job.surfaces;
  const PhysicalLight& light = *job.light;
  const size_t n = s.size();
  auto in = [&](LitSurfaces::Field f, size_t j) { return hn::LoadU(d, s.field(f) + j); };

  const V zero = hn::Zero(d);
  const V lightX = hn::Set(d, kPoint ? light.position.x() : light.toLight.x());
  const V lightY = hn::Set(d, kPoint ? light.position.y() : light.toLight.y());
  const V lightZ = hn::Set(d, kPoint ? light.position.z() : light.toLight.z());
  const V intensityR = hn::Set(d, light.intensity.x());
  const V intensityG = hn::Set(d, light.intensity.y());
  const V intensityB = hn::Set(d, light.intensity.z());
  const V worldPerPhysical = hn::Set(d, job.worldPerPhysical);
  const V infinity = hn::Set(d, std::numeric_limits<float>::infinity());
  const auto highlightBit = hn::Set(di, LitSurfaces::kHighlight);
  const auto leavesBit = hn::Set(di, LitSurfaces::kLeavesMesh);
  const auto knownBit =
      hn::Set(di, static_cast<int>(StaticHit::kLightsKnown) << LitSurfaces::kStaticLightsShift);
  const auto cachedBit =
      hn::Set(di, static_cast<int>(job.cachedBit) << LitSurfaces::kStaticLightsShift);

  StagedRays& out = *job.rays;
  float* const outField[StagedRays::kFields] = {
      out.field(StagedRays::kOx),   out.field(StagedRays::kOy), out.field(StagedRays::kOz),
      out.field(StagedRays::kDx),   out.field(StagedRays::kDy), out.field(StagedRays::kDz),
      out.field(StagedRays::kTfar), out.field(StagedRays::kR),  out.field(StagedRays::kG),
      out.field(StagedRays::kB)};
  float* dynField[StagedRays::kFields] = {};
  float* freeField[3] = {};
  if (job.cachedBit) {
    for (int f = 0; f < StagedRays::kFields; ++f)
      dynField[f] = job.dynamic->field(static_cast<StagedRays::Field>(f));
  }
  if (job.cachedBit || (job.occluders && !job.parkPassing)) {
    freeField[0] = job.unblocked->field(StagedRays::kR);
    freeField[1] = job.unblocked->field(StagedRays::kG);
    freeField[2] = job.unblocked->field(StagedRays::kB);
  }
  size_t kept = 0, keptDynamic = 0, keptFree = 0;
  ShadowRayCounts counts;
  // Appends the light of the lanes of `free` to job.unblocked.
  const auto addFree = [&](const V(&values)[StagedRays::kFields], V pixel, auto free) {
    for (int c = 0; c < 3; ++c)
      CompressAppend(d, values[StagedRays::kR + c], free, freeField[c] + keptFree);
    CompressAppend(d, pixel, free, reinterpret_cast<float*>(job.unblocked->pixels()) + keptFree);
    const size_t added = hn::CountTrue(d, free);
    keptFree += added;
    return static_cast<long>(added);
  };

  // The meshes' bounds. A directional light's rays all run along one l to an infinite tfar:
  // whether one passes a flat mesh's plane is which side of it the ray starts on (the side
  // n · l points to; none when l lies in the plane, left to the sphere).
  int planeSide[PhysicalScene::kMaxOccluders] = {};
  for (size_t k = 0; k < job.occluderCount; ++k) {
    const OccluderBound& bound = job.occluders[k];
    if (!bound.flat()) continue;
    if constexpr (kPoint) {
      planeSide[k] = 2;  // both ends tested (MayCrossPlane)
    } else {
      const Eigen::Vector3f normal = bound.plane.head<3>();
      const float along = normal.x() * light.toLight.x() +
                          (normal.y() * light.toLight.y() + normal.z() * light.toLight.z());
      planeSide[k] = along > 0.0f ? 1 : along < 0.0f ? -1 : 0;
    }
  }

  // The meshes these rays may meet (shadow_block_cull.h): a directional light's rays run
  // parallel, so surfaces far from a mesh leave it out of the loops below. A point light's rays
  // fan out: every mesh.
  std::uint8_t active[PhysicalScene::kMaxOccluders];
  size_t activeCount = 0;
  if (job.occluders) {
    if (!kPoint && job.spread) {
      activeCount = occludersWithin(*job.spread, light.toLight, job.occluders, job.occluderCount,
                                    planeSide, active);
    } else {
      for (size_t k = 0; k < job.occluderCount; ++k) active[k] = static_cast<std::uint8_t>(k);
      activeCount = job.occluderCount;
    }
  }

  for (size_t j = 0; j < n; j += lanes) {
    const auto valid = hn::FirstN(d, n - j);
    const V px = in(LitSurfaces::kPx, j), py = in(LitSurfaces::kPy, j),
            pz = in(LitSurfaces::kPz, j);
    V lx = lightX, ly = lightY, lz = lightZ, tfar = infinity;
    V irradianceR = intensityR, irradianceG = intensityG, irradianceB = intensityB;
    auto reaches = valid;
    if constexpr (kPoint) {
      const V tx = hn::Sub(lightX, px), ty = hn::Sub(lightY, py), tz = hn::Sub(lightZ, pz);
      const V distance = hn::Sqrt(Dot3(tx, ty, tz, tx, ty, tz));
      reaches = hn::And(reaches, hn::Gt(distance, zero));
      lx = hn::Div(tx, distance);
      ly = hn::Div(ty, distance);
      lz = hn::Div(tz, distance);
      tfar = distance;
      const V worldDistance = hn::Mul(distance, worldPerPhysical);
      const V square = hn::Mul(worldDistance, worldDistance);
      irradianceR = hn::Div(intensityR, square);
      irradianceG = hn::Div(intensityG, square);
      irradianceB = hn::Div(intensityB, square);
    }
    const V cosine =
        Dot3(in(LitSurfaces::kNx, j), in(LitSurfaces::kNy, j), in(LitSurfaces::kNz, j), lx, ly, lz);
    const V facing =
        Dot3(in(LitSurfaces::kGx, j), in(LitSurfaces::kGy, j), in(LitSurfaces::kGz, j), lx, ly, lz);
    // Light from behind the geometric face cannot reach this side.
    reaches = hn::And(reaches, hn::And(hn::Gt(cosine, zero), hn::Gt(facing, zero)));
    V responseR = hn::Mul(in(LitSurfaces::kDr, j), cosine);
    V responseG = hn::Mul(in(LitSurfaces::kDg, j), cosine);
    V responseB = hn::Mul(in(LitSurfaces::kDb, j), cosine);
    const auto flags = hn::LoadU(di, s.flags() + j);
    const auto highlight =
        hn::And(valid, hn::RebindMask(d, hn::Ne(hn::And(flags, highlightBit), hn::Zero(di))));
    if (!hn::AllFalse(d, highlight)) {
      // std::max(0, r·l): NaN gives 0, as in the scalar code.
      const V dot = Dot3(in(LitSurfaces::kRx, j), in(LitSurfaces::kRy, j), in(LitSurfaces::kRz, j),
                         lx, ly, lz);
      const V alignment = hn::IfThenElseZero(hn::Gt(dot, zero), dot);
      const V shininess = in(LitSurfaces::kShininess, j);
      // pow(0, s) = 0 for s > 0: only lanes facing the highlight (or s = 0) add it.
      const auto adds =
          hn::And(highlight, hn::Or(hn::Gt(alignment, zero), hn::Eq(shininess, zero)));
      if (!hn::AllFalse(d, adds)) {
        const V power = PhongPower(d, alignment, shininess, adds);
        responseR = hn::IfThenElse(
            adds, hn::Add(responseR, hn::Mul(in(LitSurfaces::kSr, j), power)), responseR);
        responseG = hn::IfThenElse(
            adds, hn::Add(responseG, hn::Mul(in(LitSurfaces::kSg, j), power)), responseG);
        responseB = hn::IfThenElse(
            adds, hn::Add(responseB, hn::Mul(in(LitSurfaces::kSb, j), power)), responseB);
      }
    }
    const V contributionR = hn::Mul(responseR, irradianceR);
    const V contributionG = hn::Mul(responseG, irradianceG);
    const V contributionB = hn::Mul(responseB, irradianceB);
    if (!job.build) {
      reaches =
          hn::And(reaches, hn::Gt(MaxCoeff3(contributionR, contributionG, contributionB), zero));
    }
    // The ray starts off the surface (offsetRayOrigin), along the geometric normal.
    const V ax = OffsetCoordinate(d, px, in(LitSurfaces::kGx, j));
    const V ay = OffsetCoordinate(d, py, in(LitSurfaces::kGy, j));
    const V az = OffsetCoordinate(d, pz, in(LitSurfaces::kGz, j));
    const V pixel = hn::BitCast(d, hn::LoadU(di, s.pixels() + j));
    const V values[StagedRays::kFields] = {
        ax, ay, az, lx, ly, lz, tfar, contributionR, contributionG, contributionB};
    auto keep = reaches;
    V tfarOut = tfar;
    if (job.cachedBit) {
      // Known static answers: blocked by a static surface (no ray), or clear (a ray against the
      // dynamic objects only).
      const auto known = hn::RebindMask(d, hn::Ne(hn::And(flags, knownBit), hn::Zero(di)));
      const auto clear = hn::RebindMask(d, hn::Ne(hn::And(flags, cachedBit), hn::Zero(di)));
      const auto toDynamic = hn::And(reaches, hn::And(known, clear));
      counts.answered +=
          static_cast<long>(hn::CountTrue(d, hn::AndNot(clear, hn::And(reaches, known))));
      keep = hn::AndNot(known, reaches);
      if (!hn::AllFalse(d, toDynamic)) {
        // Only rays that may meet a dynamic object's sphere go to Embree.
        auto meets = hn::Lt(zero, zero);
        for (size_t k = 0; k < job.sphereCount; ++k)
          meets = hn::Or(meets, MayMeetSphere(d, ax, ay, az, lx, ly, lz, tfar, job.spheres[k]));
        const auto traced = hn::And(toDynamic, meets);
        const auto free = hn::AndNot(meets, toDynamic);
        if (!hn::AllFalse(d, traced)) {
          for (int f = 0; f < StagedRays::kFields; ++f)
            CompressAppend(d, values[f], traced, dynField[f] + keptDynamic);
          CompressAppend(d, pixel, traced,
                         reinterpret_cast<float*>(job.dynamic->pixels()) + keptDynamic);
          keptDynamic += hn::CountTrue(d, traced);
        }
        if (!hn::AllFalse(d, free)) counts.passedDynamic += addFree(values, pixel, free);
      }
    }
    if (hn::AllFalse(d, keep)) continue;
    if (job.occluders) {
      // Only rays that may meet some mesh's bound go to Embree. A ray that leaves a bare face
      // of its own mesh cannot meet that mesh: its bound is not asked (it holds the ray's start).
      const auto ownMesh =
          hn::IfThenElse(hn::Ne(hn::And(flags, leavesBit), hn::Zero(di)),
                         hn::ShiftRight<LitSurfaces::kMeshShift>(flags), hn::Set(di, -1));
      auto meets = hn::Lt(zero, zero);
      for (size_t i = 0; i < activeCount; ++i) {
        const size_t k = active[i];
        const OccluderBound& bound = job.occluders[k];
        const auto others =
            hn::RebindMask(d, hn::Ne(ownMesh, hn::Set(di, static_cast<std::int32_t>(k))));
        auto may = hn::And(others, MayMeetSphere(d, ax, ay, az, lx, ly, lz, tfar, bound.sphere));
        if (bound.ring.halfHeight > 0.0f && !hn::AllFalse(d, may)) {
          may = hn::AndNot(
              MissesRing(d, ax, ay, az, lx, ly, lz, tfar, bound.ring.centre, bound.ring.axis,
                         bound.ring.inner, bound.ring.outer, bound.ring.halfHeight),
              may);
        }
        if (planeSide[k] == 2) {
          may = hn::And(
              may, MayCrossPlane(d, ax, ay, az, lx, ly, lz, tfar, bound.plane, bound.planeMargin));
        } else if (planeSide[k] != 0) {
          const V start = PlaneDistance(d, ax, ay, az, bound.plane);
          const auto stays = planeSide[k] > 0 ? hn::Gt(start, hn::Set(d, bound.planeMargin))
                                              : hn::Lt(start, hn::Set(d, -bound.planeMargin));
          may = hn::AndNot(stays, may);
        }
        meets = hn::Or(meets, may);
        if (hn::AllFalse(d, hn::AndNot(meets, keep))) break;  // all go to Embree
      }
      // A directional light's ray through another mesh's core (a closed convex mesh that stops
      // light) is blocked: neither traced nor lit.
      auto blocked = hn::Lt(zero, zero);
      if constexpr (!kPoint) {
        const auto candidates = hn::And(keep, meets);
        // A mesh left out cannot block either: its cores lie inside its bound.
        for (size_t i = 0; i < activeCount && !hn::AllFalse(d, candidates); ++i) {
          const size_t k = active[i];
          const OccluderBound& bound = job.occluders[k];
          if (!bound.hasCore()) continue;
          const auto others = hn::And(
              candidates,
              hn::RebindMask(d, hn::Ne(ownMesh, hn::Set(di, static_cast<std::int32_t>(k)))));
          for (int first = 0; first < bound.coreCount; first += OccluderBound::kCoresPerGroup) {
            const auto group = hn::AndNot(
                blocked,
                hn::And(others, MayMeetSphere(d, ax, ay, az, lx, ly, lz, infinity,
                                              bound.coreGroups[static_cast<size_t>(
                                                  first / OccluderBound::kCoresPerGroup)])));
            if (hn::AllFalse(d, group)) continue;
            const int last = std::min(bound.coreCount, first + OccluderBound::kCoresPerGroup);
            for (int c = first; c < last; ++c) {
              blocked =
                  hn::Or(blocked,
                         hn::And(group, PassesThroughSphere(d, ax, ay, az, lx, ly, lz,
                                                            bound.cores[static_cast<size_t>(c)])));
            }
          }
        }
      }
      if (!hn::AllFalse(d, blocked)) {
        counts.blockedByCores += static_cast<long>(hn::CountTrue(d, blocked));
        if (job.parkPassing) {
          // Kept in their place, blocked: tfar −∞ as Embree marks them, and Embree skips them.
          tfarOut =
              hn::IfThenElse(blocked, hn::Set(d, -std::numeric_limits<float>::infinity()), tfarOut);
        } else {
          keep = hn::AndNot(blocked, keep);
        }
      }
      const auto free = hn::AndNot(meets, keep);
      if (!hn::AllFalse(d, free)) {
        if (job.parkPassing) {
          // Kept in their place, parked: Embree skips them.
          counts.passedOccluders += static_cast<long>(hn::CountTrue(d, free));
          tfarOut = hn::IfThenElse(free, hn::Set(d, kParkedTfar), tfarOut);
        } else {
          counts.passedOccluders += addFree(values, pixel, free);
          keep = hn::And(keep, meets);
          if (hn::AllFalse(d, keep)) continue;
        }
      }
    }
    for (int f = 0; f < StagedRays::kFields; ++f)
      CompressAppend(d, f == StagedRays::kTfar ? tfarOut : values[f], keep, outField[f] + kept);
    CompressAppend(d, pixel, keep, reinterpret_cast<float*>(out.pixels()) + kept);
    kept += hn::CountTrue(d, keep);
  }
  out.setSize(kept);
  if (job.cachedBit) job.dynamic->setSize(keptDynamic);
  if (job.cachedBit || (job.occluders && !job.parkPassing)) job.unblocked->setSize(keptFree);
  return counts;
}

ShadowRayCounts MakeShadowRays(const ShadowRayJob& job) {
  return job.light->kind == LightKind::kPoint ? MakeShadowRaysFor<true>(job)
                                              : MakeShadowRaysFor<false>(job);
}

// Lanes [a, b) of a vector whose lane i adds to pixel base + i (pixels base .. base + lanes − 1
// lie in the frame): the colours loaded as three plain vectors and deinterleaved, `add` added in
// the lanes of `clear`, and the run's floats stored back. Only the run's: the pixels beside it
// may be another tile's, being drawn at the same time.
template <class D, class V = hn::Vec<D>, class M>
HWY_INLINE void AddToRun(D d, float* colours, size_t base, const V (&add)[3], M clear, size_t a,
                         size_t b) {
  const size_t lanes = hn::Lanes(d);
  float* at = colours + 3 * base;
  V c[3];
  hn::LoadInterleaved3(d, at, c[0], c[1], c[2]);
  for (int k = 0; k < 3; ++k) c[k] = hn::IfThenElse(clear, hn::Add(c[k], add[k]), c[k]);
  if (a == 0 && b == lanes) {
    hn::StoreInterleaved3(c[0], c[1], c[2], d, at);
    return;
  }
  constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(float);
  HWY_ALIGN float interleaved[3 * kMaxLanes];
  hn::StoreInterleaved3(c[0], c[1], c[2], d, interleaved);
  const hn::RebindToSigned<D> di;
  const auto from = hn::Set(di, static_cast<int>(3 * a)), to = hn::Set(di, static_cast<int>(3 * b));
  for (size_t v = 0; v < 3; ++v) {
    const auto index = hn::Iota(di, static_cast<int>(v * lanes));
    const auto inRun = hn::RebindMask(d, hn::AndNot(hn::Lt(index, from), hn::Lt(index, to)));
    if (hn::AllFalse(d, inRun)) continue;
    hn::BlendedStore(hn::Load(d, interleaved + v * lanes), inRun, d, at + v * lanes);
  }
}

// AddUnblockedLight, or with kAll every ray unblocked (packets unused).
template <bool kAll>
void AddLightOf(const StagedRays& staged, const RTCRay16* packets, Rgb* pixels) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  const size_t lanes = hn::Lanes(d);
  const size_t n = staged.size();
  const int* pixel = staged.pixels();
  const float* contribution[3] = {staged.field(StagedRays::kR), staged.field(StagedRays::kG),
                                  staged.field(StagedRays::kB)};
  float* colours = pixels->data();  // 3 floats a pixel (Rgb is Eigen's packed Vector3f)
  size_t j = 0;
  // Whole vectors only, each within one packet: a partial one would scatter to the stale pixels
  // of its unused lanes (another tile's, perhaps, being drawn at the same time).
  if (lanes <= 16 && 16 % lanes == 0) {
    constexpr size_t kMaxRuns = 3;
    const auto zero = hn::Zero(d);
    const auto three = hn::Set(di, 3);
    const auto iota = hn::Iota(di, 0);
    for (; j + lanes <= n; j += lanes) {
      // Embree sets tfar to −inf on a blocked ray (OcclusionPackets::occluded).
      const auto clear =
          kAll ? hn::Eq(zero, zero) : hn::Ge(hn::LoadU(d, packets[j / 16].tfar + j % 16), zero);
      if (!kAll && hn::AllFalse(d, clear)) continue;
      const V add[3] = {hn::LoadU(d, contribution[0] + j), hn::LoadU(d, contribution[1] + j),
                        hn::LoadU(d, contribution[2] + j)};
      const auto pixelIndex = hn::LoadU(di, pixel + j);
      // Neighbouring rays mostly light neighbouring pixels (a row of the tile): each run of
      // consecutive pixels is read and written as whole vectors, which costs far less than a
      // gather and a scatter per channel. Every pixel read lies between the vector's first and
      // last (base ≥ 0, base + lanes − 1 ≤ the last lane's pixel): inside the frame.
      const int last = pixel[j + lanes - 1];
      size_t done = 0;
      for (size_t run = 0; run < kMaxRuns && done < lanes; ++run) {
        const int base = pixel[j + done] - static_cast<int>(done);
        if (base < 0 || base + static_cast<int>(lanes) - 1 > last) break;
        const auto inRun =
            hn::Or(hn::FirstN(di, done), hn::Eq(pixelIndex, hn::Add(iota, hn::Set(di, base))));
        const size_t end =
            hn::AllTrue(di, inRun) ? lanes : hn::FindKnownFirstTrue(di, hn::Not(inRun));
        AddToRun(d, colours, static_cast<size_t>(base), add, clear, done, end);
        done = end;
      }
      if (done == lanes) continue;
      // The rest: the pixels' colours gathered, added to and scattered back.
      const auto rest = hn::And(clear, hn::Not(hn::FirstN(d, done)));
      const auto index = hn::Mul(pixelIndex, three);
      for (int c = 0; c < 3; ++c) {
        const auto before = hn::GatherIndex(d, colours + c, index);
        const auto after = hn::Add(before, add[c]);
        // A lane left out writes back what it read: the same bits.
        hn::ScatterIndex(hn::IfThenElse(rest, after, before), d, colours + c, index);
      }
    }
  }
  for (; j < n; ++j) {
    if (kAll || packets[j / 16].tfar[j % 16] >= 0.0f)
      pixels[pixel[j]] += Rgb(contribution[0][j], contribution[1][j], contribution[2][j]);
  }
}

void AddUnblockedLight(const StagedRays& staged, const RTCRay16* packets, Rgb* pixels) {
  AddLightOf<false>(staged, packets, pixels);
}

void AddLight(const StagedRays& staged, Rgb* pixels) { AddLightOf<true>(staged, nullptr, pixels); }

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace parallax {

HWY_EXPORT(MakeShadowRays);
HWY_EXPORT(AddUnblockedLight);
HWY_EXPORT(AddLight);

ShadowRayCounts makeShadowRays(const ShadowRayJob& job) {
  return HWY_DYNAMIC_DISPATCH(MakeShadowRays)(job);
}

void addUnblockedLight(const StagedRays& staged, const RTCRay16* packets, Rgb* pixels) {
  HWY_DYNAMIC_DISPATCH(AddUnblockedLight)(staged, packets, pixels);
}

void addLight(const StagedRays& staged, Rgb* pixels) {
  HWY_DYNAMIC_DISPATCH(AddLight)(staged, pixels);
}

}  // namespace parallax
#endif
