// Compiled once per instruction set by Highway's foreach_target, as shadow_ray_kernel.cpp is.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3  // SSSE3 without SSE4 (CPUs before 2008): one compile less
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tracer/diffuse_hit_kernel.cpp"
#include "tracer/diffuse_hit_kernel.h"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "tracer/simd_math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace parallax {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// What a vector of lanes needs of the triangles they hit: each corner's position and (where the
// mesh has them) normal, and the face normal, coordinate by coordinate.
template <class V>
struct TriangleCorners {
  V position[3][3];  // [corner][coordinate]
  V normal[3][3];
  V face[3];
};

// The corners by gathers, lane by lane (`prim` in range in every lane).
template <class D, class DI, class V = hn::Vec<D>>
HWY_INLINE void GatherCorners(D d, DI di, const PhysicalMesh& mesh, hn::Vec<DI> prim,
                              TriangleCorners<V>* corners) {
  const auto* triangles = reinterpret_cast<const std::int32_t*>(mesh.triangles.data());
  const float* positions = mesh.positions.data()->data();
  const float* faceNormals = mesh.faceNormals.data()->data();
  const float* vertexNormals = mesh.normals.empty() ? nullptr : mesh.normals.data()->data();
  const auto three = hn::Set(di, 3);
  const auto prim3 = hn::Mul(prim, three);
  for (int k = 0; k < 3; ++k) {
    const auto vertex =
        hn::Mul(hn::GatherIndex(di, triangles, hn::Add(prim3, hn::Set(di, k))), three);
    for (int c = 0; c < 3; ++c) {
      const auto offset = hn::Add(vertex, hn::Set(di, c));
      corners->position[k][c] = hn::GatherIndex(d, positions, offset);
      if (vertexNormals) corners->normal[k][c] = hn::GatherIndex(d, vertexNormals, offset);
    }
  }
  for (int c = 0; c < 3; ++c)
    corners->face[c] = hn::GatherIndex(d, faceNormals, hn::Add(prim3, hn::Set(di, c)));
}

// The corners when the lanes of `lanes` met at most kMaxTriangles triangles (primary rays are
// coherent: neighbouring pixels mostly meet one triangle, or two across an edge): each
// triangle's values read once and broadcast to its lanes, far cheaper than a gather per value.
// False (corners unfinished) when there are more.
template <class D, class DI, class V = hn::Vec<D>, class M>
HWY_INLINE bool BroadcastCorners(D d, DI di, const PhysicalMesh& mesh, hn::Vec<DI> prim,
                                 const std::uint32_t* primOfLane, M lanes,
                                 TriangleCorners<V>* corners) {
  constexpr int kMaxTriangles = 3;
  const bool vertexNormals = !mesh.normals.empty();
  auto remaining = lanes;
  for (int t = 0; t < kMaxTriangles; ++t) {
    if (hn::AllFalse(di, remaining)) return true;
    const std::uint32_t p = primOfLane[hn::FindKnownFirstTrue(di, remaining)];
    const auto same = hn::RebindMask(d, hn::Eq(prim, hn::Set(di, static_cast<std::int32_t>(p))));
    remaining = hn::AndNot(hn::RebindMask(di, same), remaining);
    const auto put = [&](V* to, float value) {
      *to = t == 0 ? hn::Set(d, value) : hn::IfThenElse(same, hn::Set(d, value), *to);
    };
    const auto& triangle = mesh.triangles[p];
    for (int k = 0; k < 3; ++k) {
      for (int c = 0; c < 3; ++c) {
        put(&corners->position[k][c], mesh.positions[triangle[k]][c]);
        if (vertexNormals) put(&corners->normal[k][c], mesh.normals[triangle[k]][c]);
      }
    }
    for (int c = 0; c < 3; ++c) put(&corners->face[c], mesh.faceNormals[p][c]);
  }
  return hn::AllFalse(di, remaining);
}

// kMasked: the packet met other meshes (or missed) too; only this mesh's lanes are written.
template <bool kMasked>
bool ShadeDiffuseLanes(const RTCRayHit16& packet, unsigned geomID, const PhysicalMesh& mesh,
                       const Material& material, LitSurfaces* lit, size_t first) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  const size_t lanes = hn::Lanes(d);
  if (lanes > 16 || 16 % lanes != 0) return false;
  const bool vertexNormals = !mesh.normals.empty();
  const bool highlight = material.specular.maxCoeff() > 0.0f;
  const V one = hn::Set(d, 1.0f), zero = hn::Zero(d), two = hn::Set(d, 2.0f);
  auto out = [&](LitSurfaces::Field f, size_t j) { return lit->mutableField(f) + first + j; };
  const auto mesh32 = hn::Set(di, static_cast<std::int32_t>(geomID));
  for (size_t j = 0; j < 16; j += lanes) {
    // This mesh's lanes; the others read its first triangle (in bounds) and store nothing.
    const auto mineI =
        hn::Eq(hn::LoadU(di, reinterpret_cast<const std::int32_t*>(packet.hit.geomID + j)), mesh32);
    if (kMasked && hn::AllFalse(di, mineI)) continue;
    const auto mine = hn::RebindMask(d, mineI);
    auto prim = hn::LoadU(di, reinterpret_cast<const std::int32_t*>(packet.hit.primID + j));
    if constexpr (kMasked) prim = hn::IfThenElseZero(mineI, prim);
    const auto store = [&](V value, LitSurfaces::Field f) {
      if constexpr (kMasked) {
        hn::BlendedStore(value, mine, d, out(f, j));
      } else {
        hn::StoreU(value, d, out(f, j));
      }
    };
    TriangleCorners<V> corners;
    if (!BroadcastCorners(d, di, mesh, prim, packet.hit.primID + j, mineI, &corners))
      GatherCorners(d, di, mesh, prim, &corners);
    const V u = hn::LoadU(d, packet.hit.u + j), v = hn::LoadU(d, packet.hit.v + j);
    const V w = hn::Sub(hn::Sub(one, u), v);
    // From the vertices, not o + t d (hit_info.h says why): w p0 + u p1 + v p2.
    const auto interpolate = [&](const V(&a)[3][3], int c) {
      return hn::Add(hn::Add(hn::Mul(w, a[0][c]), hn::Mul(u, a[1][c])), hn::Mul(v, a[2][c]));
    };
    V position[3];
    for (int c = 0; c < 3; ++c) position[c] = interpolate(corners.position, c);
    // The face normal, turned toward the incoming ray.
    const V dx = hn::LoadU(d, packet.ray.dir_x + j), dy = hn::LoadU(d, packet.ray.dir_y + j),
            dz = hn::LoadU(d, packet.ray.dir_z + j);
    V normal[3] = {corners.face[0], corners.face[1], corners.face[2]};
    const auto back = hn::Not(hn::Lt(Dot3(normal[0], normal[1], normal[2], dx, dy, dz), zero));
    for (V& n : normal) n = hn::IfThenElse(back, hn::Neg(n), n);
    // The shading normal: the vertex normals interpolated, normalised and kept on the incoming
    // side; the face normal where they cancel out.
    V shading[3] = {normal[0], normal[1], normal[2]};
    if (vertexNormals) {
      V interpolated[3];
      for (int c = 0; c < 3; ++c) interpolated[c] = interpolate(corners.normal, c);
      const V length = hn::Sqrt(Dot3(interpolated[0], interpolated[1], interpolated[2],
                                     interpolated[0], interpolated[1], interpolated[2]));
      const auto usable = hn::And(hn::Gt(length, zero), hn::IsFinite(length));
      for (V& n : interpolated) n = hn::Div(n, length);
      const auto flip = hn::Lt(
          Dot3(interpolated[0], interpolated[1], interpolated[2], normal[0], normal[1], normal[2]),
          zero);
      for (int c = 0; c < 3; ++c) {
        const V n = hn::IfThenElse(flip, hn::Neg(interpolated[c]), interpolated[c]);
        shading[c] = hn::IfThenElse(usable, n, normal[c]);
      }
    }

    store(position[0], LitSurfaces::kPx);
    store(position[1], LitSurfaces::kPy);
    store(position[2], LitSurfaces::kPz);
    store(shading[0], LitSurfaces::kNx);
    store(shading[1], LitSurfaces::kNy);
    store(shading[2], LitSurfaces::kNz);
    store(normal[0], LitSurfaces::kGx);
    store(normal[1], LitSurfaces::kGy);
    store(normal[2], LitSurfaces::kGz);
    // A first-generation path's weight is 1: weight × albedo is the albedo.
    store(hn::Set(d, material.diffuse.x()), LitSurfaces::kDr);
    store(hn::Set(d, material.diffuse.y()), LitSurfaces::kDg);
    store(hn::Set(d, material.diffuse.z()), LitSurfaces::kDb);
    if (highlight) {
      // reflect(d, n) = d − 2 (d·n) n.
      const V twice = hn::Mul(two, Dot3(dx, dy, dz, shading[0], shading[1], shading[2]));
      store(hn::Sub(dx, hn::Mul(twice, shading[0])), LitSurfaces::kRx);
      store(hn::Sub(dy, hn::Mul(twice, shading[1])), LitSurfaces::kRy);
      store(hn::Sub(dz, hn::Mul(twice, shading[2])), LitSurfaces::kRz);
      store(hn::Set(d, material.specular.x()), LitSurfaces::kSr);
      store(hn::Set(d, material.specular.y()), LitSurfaces::kSg);
      store(hn::Set(d, material.specular.z()), LitSurfaces::kSb);
      store(hn::Set(d, material.shininess), LitSurfaces::kShininess);
    }
    auto flags = hn::Set(
        di, (highlight ? LitSurfaces::kHighlight : 0) | LitSurfaces::meshFlags(geomID, false));
    if (!mesh.bareFaces.empty()) {
      // The face the ray met: the back one where the normal was turned round.
      const auto bare = hn::GatherIndex(di, mesh.bareFaces.data(), prim);
      const auto side =
          hn::IfThenElse(hn::RebindMask(di, back), hn::Set(di, PhysicalMesh::kBackBare),
                         hn::Set(di, PhysicalMesh::kFrontBare));
      flags = hn::IfThenElse(hn::Ne(hn::And(bare, side), hn::Zero(di)),
                             hn::Or(flags, hn::Set(di, LitSurfaces::kLeavesMesh)), flags);
    }
    if constexpr (kMasked) {
      hn::BlendedStore(flags, mineI, di, lit->mutableFlags() + first + j);
    } else {
      hn::StoreU(flags, di, lit->mutableFlags() + first + j);
    }
  }
  return true;
}

bool ShadeDiffusePacket(const RTCRayHit16& packet, unsigned geomID, const PhysicalMesh& mesh,
                        const Material& material, LitSurfaces* lit, size_t first,
                        bool wholePacket) {
  return wholePacket ? ShadeDiffuseLanes<false>(packet, geomID, mesh, material, lit, first)
                     : ShadeDiffuseLanes<true>(packet, geomID, mesh, material, lit, first);
}

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace parallax {

HWY_EXPORT(ShadeDiffusePacket);

bool shadeDiffusePacket(const RTCRayHit16& packet, unsigned geomID, const PhysicalMesh& mesh,
                        const Material& material, LitSurfaces* lit, size_t first,
                        bool wholePacket) {
  return HWY_DYNAMIC_DISPATCH(ShadeDiffusePacket)(packet, geomID, mesh, material, lit, first,
                                                  wholePacket);
}

}  // namespace parallax
#endif
