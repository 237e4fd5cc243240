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

bool ShadeDiffusePacket(const RTCRayHit16& packet, const PhysicalMesh& mesh,
                        const Material& material, LitSurfaces* lit) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  const size_t lanes = hn::Lanes(d);
  if (lanes > 16 || 16 % lanes != 0) return false;
  const size_t first = lit->extend(16);
  const auto* triangles = reinterpret_cast<const std::int32_t*>(mesh.triangles.data());
  const float* positions = mesh.positions.data()->data();
  const float* faceNormals = mesh.faceNormals.data()->data();
  const float* vertexNormals = mesh.normals.empty() ? nullptr : mesh.normals.data()->data();
  const bool highlight = material.specular.maxCoeff() > 0.0f;
  const V one = hn::Set(d, 1.0f), zero = hn::Zero(d), two = hn::Set(d, 2.0f);
  const auto three = hn::Set(di, 3);
  auto out = [&](LitSurfaces::Field f, size_t j) { return lit->mutableField(f) + first + j; };
  for (size_t j = 0; j < 16; j += lanes) {
    const auto prim3 =
        hn::Mul(hn::LoadU(di, reinterpret_cast<const std::int32_t*>(packet.hit.primID + j)), three);
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

    hn::StoreU(position[0], d, out(LitSurfaces::kPx, j));
    hn::StoreU(position[1], d, out(LitSurfaces::kPy, j));
    hn::StoreU(position[2], d, out(LitSurfaces::kPz, j));
    hn::StoreU(shading[0], d, out(LitSurfaces::kNx, j));
    hn::StoreU(shading[1], d, out(LitSurfaces::kNy, j));
    hn::StoreU(shading[2], d, out(LitSurfaces::kNz, j));
    hn::StoreU(normal[0], d, out(LitSurfaces::kGx, j));
    hn::StoreU(normal[1], d, out(LitSurfaces::kGy, j));
    hn::StoreU(normal[2], d, out(LitSurfaces::kGz, j));
    // A first-generation path's weight is 1: weight × albedo is the albedo.
    hn::StoreU(hn::Set(d, material.diffuse.x()), d, out(LitSurfaces::kDr, j));
    hn::StoreU(hn::Set(d, material.diffuse.y()), d, out(LitSurfaces::kDg, j));
    hn::StoreU(hn::Set(d, material.diffuse.z()), d, out(LitSurfaces::kDb, j));
    if (highlight) {
      // reflect(d, n) = d − 2 (d·n) n.
      const V twice = hn::Mul(two, Dot3(dx, dy, dz, shading[0], shading[1], shading[2]));
      hn::StoreU(hn::Sub(dx, hn::Mul(twice, shading[0])), d, out(LitSurfaces::kRx, j));
      hn::StoreU(hn::Sub(dy, hn::Mul(twice, shading[1])), d, out(LitSurfaces::kRy, j));
      hn::StoreU(hn::Sub(dz, hn::Mul(twice, shading[2])), d, out(LitSurfaces::kRz, j));
      hn::StoreU(hn::Set(d, material.specular.x()), d, out(LitSurfaces::kSr, j));
      hn::StoreU(hn::Set(d, material.specular.y()), d, out(LitSurfaces::kSg, j));
      hn::StoreU(hn::Set(d, material.specular.z()), d, out(LitSurfaces::kSb, j));
      hn::StoreU(hn::Set(d, material.shininess), d, out(LitSurfaces::kShininess, j));
    }
    hn::StoreU(hn::Set(di, highlight ? LitSurfaces::kHighlight : 0), di,
               lit->mutableFlags() + first + j);
  }
  return true;
}

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace parallax {

HWY_EXPORT(ShadeDiffusePacket);

bool shadeDiffusePacket(const RTCRayHit16& packet, const PhysicalMesh& mesh,
                        const Material& material, LitSurfaces* lit) {
  return HWY_DYNAMIC_DISPATCH(ShadeDiffusePacket)(packet, mesh, material, lit);
}

}  // namespace parallax
#endif
