// Compiled once per instruction set by Highway's foreach_target, as shadow_ray_kernel.cpp is.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3  // SSSE3 without SSE4 (CPUs before 2008): one compile less
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tracer/static_hit_kernel.cpp"
#include "tracer/static_hit_kernel.h"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>

#include "tracer/simd_math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace parallax {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The static ordinal (StaticVisibilityView::triangleBase) of the cache's triangle number.
size_t StaticOrdinalOf(const StaticVisibilityView& view, std::uint32_t triangle) {
  const std::uint32_t* end = view.triangleBase + view.staticMeshes + 1;
  return static_cast<size_t>(std::upper_bound(view.triangleBase, end, triangle) -
                             view.triangleBase) -
         1;
}

// The corners' positions, [corner][coordinate], of the triangles `prim` of one mesh in the
// lanes of `lanes` (the others read triangle 0). Primary rays are coherent: neighbouring pixels
// mostly meet one triangle, or two across an edge, so up to three triangles are read once and
// broadcast to their lanes; more, one gather a value.
template <class D, class DI, class V = hn::Vec<D>, class M>
HWY_INLINE void CornerPositions(D d, DI di, const PhysicalMesh& mesh, hn::Vec<DI> prim, M lanes,
                                V (*corner)[3]) {
  constexpr int kBroadcastTriangles = 3;
  HWY_ALIGN std::int32_t primOfLane[hn::MaxLanes(DI())];
  hn::Store(prim, di, primOfLane);
  auto remaining = lanes;
  for (int t = 0; t < kBroadcastTriangles && !hn::AllFalse(di, remaining); ++t) {
    const std::int32_t p = primOfLane[hn::FindKnownFirstTrue(di, remaining)];
    const auto same = hn::Eq(prim, hn::Set(di, p));
    remaining = hn::AndNot(same, remaining);
    const auto& triangle = mesh.triangles[static_cast<size_t>(p)];
    for (int k = 0; k < 3; ++k) {
      for (int c = 0; c < 3; ++c) {
        const V value = hn::Set(d, mesh.positions[triangle[static_cast<size_t>(k)]][c]);
        corner[k][c] =
            t == 0 ? value : hn::IfThenElse(hn::RebindMask(d, same), value, corner[k][c]);
      }
    }
  }
  if (hn::AllFalse(di, remaining)) return;
  const auto* triangles = reinterpret_cast<const std::int32_t*>(mesh.triangles.data());
  const float* positions = mesh.positions.data()->data();
  const auto three = hn::Set(di, 3);
  const auto prim3 = hn::Mul(hn::IfThenElseZero(lanes, prim), three);
  for (int k = 0; k < 3; ++k) {
    const auto vertex =
        hn::Mul(hn::GatherIndex(di, triangles, hn::Add(prim3, hn::Set(di, k))), three);
    for (int c = 0; c < 3; ++c)
      corner[k][c] = hn::GatherIndex(d, positions, hn::Add(vertex, hn::Set(di, c)));
  }
}

void LimitToStaticHits(const StaticHitJob& job) {
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "gathered as a float array");
  static_assert(sizeof(StaticHit) == 3 * sizeof(float), "u, v, packed: gathered as 3 words");
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  using VI = hn::Vec<decltype(di)>;
  constexpr size_t kMaxLanes = hn::MaxLanes(decltype(d)());
  const size_t lanes = hn::Lanes(d);  // 1, 4, 8 or 16: a packet's 16 lanes are whole vectors
  const StaticVisibilityView& view = *job.view;
  CachedHits& out = *job.hits;
  const auto* words = reinterpret_cast<const float*>(view.hits);
  const auto* packed = reinterpret_cast<const std::int32_t*>(view.hits);
  const VI noTriangle = hn::Set(di, static_cast<std::int32_t>(StaticHit::kNoTriangle));
  const VI three = hn::Set(di, 3), none = hn::Set(di, -1);
  const V one = hn::Set(d, 1.0f), zero = hn::Zero(d);
  // Whether every lane of `hit` holds a triangle of static mesh `ordinal`.
  const auto allIn = [&](VI triangle, auto hit, size_t ordinal) {
    const auto from = hn::Set(di, static_cast<std::int32_t>(view.triangleBase[ordinal]) - 1);
    const auto to = hn::Set(di, static_cast<std::int32_t>(view.triangleBase[ordinal + 1]));
    return hn::AllFalse(di, hn::AndNot(hn::And(hn::Gt(triangle, from), hn::Lt(triangle, to)), hit));
  };
  size_t ordinal = 0;  // the static mesh of the previous vector's hits
  for (size_t i = 0; i < job.rays; i += lanes) {
    RTCRay16& ray = job.packets[i / 16].ray;
    const size_t j = i % 16;
    const auto valid = hn::FirstN(di, job.rays - i);
    const VI record = hn::Mul(hn::IfThenElseZero(valid, hn::LoadU(di, job.pixels + i)), three);
    const VI bits = hn::GatherIndex(di, packed, hn::Add(record, hn::Set(di, 2)));
    const VI triangle = hn::And(bits, noTriangle);
    const auto hit = hn::And(valid, hn::Ne(triangle, noTriangle));
    VI mesh = none, prim = hn::Zero(di);
    V corner[3][3];
    if (!hn::AllFalse(di, hit)) {
      bool oneMesh = allIn(triangle, hit, ordinal);
      if (!oneMesh) {
        HWY_ALIGN std::int32_t triangleOfLane[kMaxLanes];
        hn::Store(triangle, di, triangleOfLane);
        ordinal = StaticOrdinalOf(
            view, static_cast<std::uint32_t>(triangleOfLane[hn::FindKnownFirstTrue(di, hit)]));
        oneMesh = allIn(triangle, hit, ordinal);
      }
      if (oneMesh) {
        const int meshIndex = view.meshOfStatic[ordinal];
        mesh = hn::Set(di, meshIndex);
        prim = hn::IfThenElseZero(
            hit,
            hn::Sub(triangle, hn::Set(di, static_cast<std::int32_t>(view.triangleBase[ordinal]))));
        CornerPositions(d, di, job.meshes[meshIndex], prim, hit, corner);
      } else {
        // Lanes on several meshes (an edge between two): lane by lane.
        HWY_ALIGN std::int32_t triangleOfLane[kMaxLanes], hitOfLane[kMaxLanes];
        HWY_ALIGN std::int32_t meshOfLane[kMaxLanes], primOfLane[kMaxLanes];
        HWY_ALIGN float cornerOfLane[3][3][kMaxLanes];
        hn::Store(triangle, di, triangleOfLane);
        hn::Store(hn::VecFromMask(di, hit), di, hitOfLane);
        for (size_t lane = 0; lane < lanes; ++lane) {
          meshOfLane[lane] = -1;
          primOfLane[lane] = 0;
          for (auto& k : cornerOfLane)
            for (auto& c : k) c[lane] = 0.0f;
          if (!hitOfLane[lane]) continue;
          const auto t = static_cast<std::uint32_t>(triangleOfLane[lane]);
          const size_t o = StaticOrdinalOf(view, t);
          meshOfLane[lane] = view.meshOfStatic[o];
          primOfLane[lane] = static_cast<std::int32_t>(t - view.triangleBase[o]);
          const PhysicalMesh& m = job.meshes[meshOfLane[lane]];
          const auto& tri = m.triangles[static_cast<size_t>(primOfLane[lane])];
          for (int k = 0; k < 3; ++k)
            for (int c = 0; c < 3; ++c)
              cornerOfLane[k][c][lane] = m.positions[tri[static_cast<size_t>(k)]][c];
        }
        mesh = hn::Load(di, meshOfLane);
        prim = hn::Load(di, primOfLane);
        for (int k = 0; k < 3; ++k)
          for (int c = 0; c < 3; ++c) corner[k][c] = hn::Load(d, cornerOfLane[k][c]);
      }
    }
    hn::StoreU(hn::IfThenElse(hit, mesh, none), di, out.mesh.data() + i);
    hn::StoreU(prim, di, out.prim.data() + i);
    hn::StoreU(hn::And(hn::ShiftRight<24>(bits), hn::Set(di, 0xFF)), di, out.lights.data() + i);
    if (hn::AllFalse(di, hit)) {
      hn::StoreU(hn::Zero(di), di, out.parked.data() + i);
      continue;
    }
    // The hit point as hitInfoOf computes it, (1 − u − v) p0 + u p1 + v p2; its distance along
    // the (unit) ray.
    const V u = hn::GatherIndex(d, words, record);
    const V v = hn::GatherIndex(d, words, hn::Add(record, hn::Set(di, 1)));
    const V w = hn::Sub(hn::Sub(one, u), v);
    V toHit[3];
    const float* origin[3] = {ray.org_x + j, ray.org_y + j, ray.org_z + j};
    for (int c = 0; c < 3; ++c) {
      const V p = hn::Add(hn::Add(hn::Mul(w, corner[0][c]), hn::Mul(u, corner[1][c])),
                          hn::Mul(v, corner[2][c]));
      toHit[c] = hn::Sub(p, hn::LoadU(d, origin[c]));
    }
    const V ox = hn::LoadU(d, origin[0]), oy = hn::LoadU(d, origin[1]),
            oz = hn::LoadU(d, origin[2]);
    const V dx = hn::LoadU(d, ray.dir_x + j), dy = hn::LoadU(d, ray.dir_y + j),
            dz = hn::LoadU(d, ray.dir_z + j);
    const V t = Dot3(toHit[0], toHit[1], toHit[2], dx, dy, dz);
    auto meets = hn::Lt(zero, zero);
    for (size_t k = 0; k < job.sphereCount; ++k)
      meets = hn::Or(meets, MayMeetSphere(d, ox, oy, oz, dx, dy, dz, t, job.spheres[k]));
    // Nothing dynamic lies in front of the static hit: the lane is parked (tnear > tfar, as the
    // stream traversal parks unused lanes), and a packet of such lanes costs Embree next to
    // nothing. The others are traced only as far as the static hit.
    const auto hitF = hn::RebindMask(d, hit);
    const auto parked = hn::AndNot(meets, hitF);
    hn::StoreU(hn::IfThenElse(parked, one, hn::LoadU(d, ray.tnear + j)), d, ray.tnear + j);
    hn::StoreU(hn::IfThenElse(parked, zero, hn::IfThenElse(hitF, t, hn::LoadU(d, ray.tfar + j))), d,
               ray.tfar + j);
    hn::StoreU(hn::VecFromMask(di, hn::RebindMask(di, parked)), di, out.parked.data() + i);
    hn::StoreU(t, d, out.t.data() + i);
    hn::StoreU(u, d, out.u.data() + i);
    hn::StoreU(v, d, out.v.data() + i);
  }
}

long TakeStaticHits(const StaticHitJob& job, std::uint8_t* lights, long* reused) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const hn::Rebind<std::uint8_t, decltype(di)> d8;
  using V = hn::Vec<decltype(d)>;
  const size_t lanes = hn::Lanes(d);
  const CachedHits& in = *job.hits;
  const V zero = hn::Zero(d);
  const auto none = hn::Set(di, -1);
  long parkedCount = 0, taken = 0;
  for (size_t i = 0; i < job.rays; i += lanes) {
    RTCRayHit16& packet = job.packets[i / 16];
    const size_t j = i % 16;
    const auto valid = hn::FirstN(di, job.rays - i);
    // The parked lanes get back their tnear of 0 and their distance to the static hit.
    const auto parked = hn::RebindMask(
        d, hn::And(valid, hn::Ne(hn::LoadU(di, in.parked.data() + i), hn::Zero(di))));
    const V t = hn::LoadU(d, in.t.data() + i);
    hn::StoreU(hn::IfThenElse(parked, zero, hn::LoadU(d, packet.ray.tnear + j)), d,
               packet.ray.tnear + j);
    hn::StoreU(hn::IfThenElse(parked, t, hn::LoadU(d, packet.ray.tfar + j)), d,
               packet.ray.tfar + j);
    parkedCount += static_cast<long>(hn::CountTrue(d, parked));
    // Where the dynamic objects gave nothing nearer, the static hit.
    auto* geomID = reinterpret_cast<std::int32_t*>(packet.hit.geomID + j);
    auto* primID = reinterpret_cast<std::int32_t*>(packet.hit.primID + j);
    const auto geom = hn::LoadU(di, geomID);
    const auto mesh = hn::LoadU(di, in.mesh.data() + i);
    const auto take = hn::And(valid, hn::And(hn::Ne(mesh, none), hn::Eq(geom, none)));
    const auto takeF = hn::RebindMask(d, take);
    hn::StoreU(hn::IfThenElse(take, mesh, geom), di, geomID);
    hn::StoreU(hn::IfThenElse(take, hn::LoadU(di, in.prim.data() + i), hn::LoadU(di, primID)), di,
               primID);
    hn::StoreU(hn::IfThenElse(takeF, hn::LoadU(d, in.u.data() + i), hn::LoadU(d, packet.hit.u + j)),
               d, packet.hit.u + j);
    hn::StoreU(hn::IfThenElse(takeF, hn::LoadU(d, in.v.data() + i), hn::LoadU(d, packet.hit.v + j)),
               d, packet.hit.v + j);
    const auto light = hn::IfThenElseZero(take, hn::LoadU(di, in.lights.data() + i));
    hn::StoreU(hn::DemoteTo(d8, light), d8, lights + i);
    taken += static_cast<long>(hn::CountTrue(di, take));
  }
  *reused = taken;
  return parkedCount;
}

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace parallax {

HWY_EXPORT(LimitToStaticHits);
HWY_EXPORT(TakeStaticHits);

void limitToStaticHits(const StaticHitJob& job) { HWY_DYNAMIC_DISPATCH(LimitToStaticHits)(job); }

long takeStaticHits(const StaticHitJob& job, std::uint8_t* lights, long* reused) {
  return HWY_DYNAMIC_DISPATCH(TakeStaticHits)(job, lights, reused);
}

}  // namespace parallax
#endif
