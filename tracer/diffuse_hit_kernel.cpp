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

// kMasked: the packet met other meshes (or missed) too; only this mesh's lanes are written.
template <bool kMasked>
bool ShadeDiffuseLanes(const RTCRayHit16& packet, unsigned geomID, const PhysicalMesh& mesh,
                       const Material& material, LitSurfaces* lit, size_t first) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  const size_t lanes = hn::Lanes(d);
  if (lanes > 16 || 16 % lanes != 0) return false;
  const auto* triangles = reinterpret_cast<const std::int32_t*>(mesh.triangles.data());
  const float* positions = mesh.positions.data()->data();
  const float* faceNormals = mesh.faceNormals.data()->data();
  const float* vertexNormals = mesh.normals.empty() ? nullptr : mesh.normals.data()->data();
  const bool highlight = material.specular.maxCoeff() > 0.0f;
  const V one = hn::Set(d, 1.0f), zero = hn::Zero(d), two = hn::Set(d, 2.0f);
  const auto three = hn::Set(di, 3);
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
    const auto prim3 = hn::Mul(prim, three);
    const auto store = [&](V value, LitSurfaces::Field f) {
      if constexpr (kMasked) {
        hn::BlendedStore(value, mine, d, out(f, j));
      } else {
        hn::StoreU(value, d, out(f, j));
      }
    };
    const V u = hn::LoadU(d, packet.hit.u + j), v = hn::LoadU(d, packet.hit.v + j);
    const V w = hn::Sub(hn::Sub(one, u), v);
    // From the vertices, not o + t d (hit_info.h says why): w p0 + u p1 + v p2.
    V position[3];
    const auto vertex0 = hn::Mul(hn::GatherIndex(di, triangles, prim3), three);
    const auto vertex1 =
        hn::Mul(hn::GatherIndex(di, triangles, hn::Add(prim3, hn::Set(di, 1))), three);
    const auto vertex2 =
        hn::Mul(hn::GatherIndex(di, triangles, hn::Add(prim3, hn::Set(di, 2))), three);
    // Coordinate c of a per-vertex attribute (3 floats a vertex) at the hit: w a0 + u a1 + v a2.
    const auto interpolate = [&](const float* attribute, int c) {
      const auto offset = hn::Set(di, c);
      const V a0 = hn::GatherIndex(d, attribute, hn::Add(vertex0, offset));
      const V a1 = hn::GatherIndex(d, attribute, hn::Add(vertex1, offset));
      const V a2 = hn::GatherIndex(d, attribute, hn::Add(vertex2, offset));
      return hn::Add(hn::Add(hn::Mul(w, a0), hn::Mul(u, a1)), hn::Mul(v, a2));
    };
    for (int c = 0; c < 3; ++c) position[c] = interpolate(positions, c);
    // The face normal, turned toward the incoming ray.
    const V dx = hn::LoadU(d, packet.ray.dir_x + j), dy = hn::LoadU(d, packet.ray.dir_y + j),
            dz = hn::LoadU(d, packet.ray.dir_z + j);
    V normal[3];
    for (int c = 0; c < 3; ++c)
      normal[c] = hn::GatherIndex(d, faceNormals, hn::Add(prim3, hn::Set(di, c)));
    const auto back = hn::Not(hn::Lt(Dot3(normal[0], normal[1], normal[2], dx, dy, dz), zero));
    for (V& n : normal) n = hn::IfThenElse(back, hn::Neg(n), n);
    // The shading normal: the vertex normals interpolated, normalised and kept on the incoming
    // side; the face normal where they cancel out.
    V shading[3] = {normal[0], normal[1], normal[2]};
    if (vertexNormals) {
      V interpolated[3];
      for (int c = 0; c < 3; ++c) interpolated[c] = interpolate(vertexNormals, c);
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
    const auto flags = hn::Set(di, highlight ? LitSurfaces::kHighlight : 0);
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
