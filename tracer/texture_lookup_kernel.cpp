// Compiled once per instruction set by Highway's foreach_target, as shadow_ray_kernel.cpp is.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3  // SSSE3 without SSE4 (CPUs before 2008): one compile less
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tracer/texture_lookup_kernel.cpp"
#include "tracer/texture_lookup_kernel.h"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cmath>

#include "tracer/simd_math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace parallax {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// wrapFloor (texture_image.h) of the whole floats `f` in the lanes of `lanes`; 0 in the others.
// In range, the int itself; out of range (a uv outside [0, 1] on a repeating texture), the
// scalar function lane by lane.
template <class D, class DI, class M>
HWY_INLINE hn::Vec<DI> WrapFloor(D d, DI di, hn::Vec<D> f, int n, M lanes) {
  const auto i = hn::ConvertTo(di, f);
  const auto inside = hn::And(hn::Gt(i, hn::Set(di, -1)), hn::Lt(i, hn::Set(di, n)));
  if (hn::AllFalse(di, hn::AndNot(inside, lanes))) return hn::IfThenElseZero(lanes, i);
  constexpr size_t kMaxLanes = hn::MaxLanes(D());
  HWY_ALIGN float value[kMaxLanes];
  HWY_ALIGN std::int32_t use[kMaxLanes], wrapped[kMaxLanes];
  hn::Store(f, d, value);
  hn::Store(hn::VecFromMask(di, lanes), di, use);
  for (size_t lane = 0; lane < hn::Lanes(d); ++lane)
    wrapped[lane] = use[lane] ? wrapFloor(value[lane], n) : 0;
  return hn::Load(di, wrapped);
}

// TextureImage::bilinear of `level` at (u, v) in the lanes of `lanes` (the others read texel 0).
template <class D, class DI, class V = hn::Vec<D>, class M>
HWY_INLINE void Bilinear(D d, DI di, const TextureImage::LevelView& level, V u, V v, M lanes,
                         V* out) {
  const V one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);
  // uv (0,0) is the bottom-left corner; texel centres sit at half-integers.
  const V x = hn::Sub(hn::Mul(u, hn::Set(d, static_cast<float>(level.width))), half);
  const V y = hn::Sub(hn::Mul(hn::Sub(one, v), hn::Set(d, static_cast<float>(level.height))), half);
  const V fx = hn::Floor(x), fy = hn::Floor(y);
  const V ax = hn::Sub(x, fx), ay = hn::Sub(y, fy);
  const auto x0 = WrapFloor(d, di, fx, level.width, lanes);
  const auto y0 = WrapFloor(d, di, fy, level.height, lanes);
  const auto next = [&](auto i, int n) {
    const auto i1 = hn::Add(i, hn::Set(di, 1));
    return hn::IfThenZeroElse(hn::Eq(i1, hn::Set(di, n)), i1);
  };
  const auto x1 = next(x0, level.width), y1 = next(y0, level.height);
  const auto three = hn::Set(di, 3), width = hn::Set(di, level.width);
  const auto row0 = hn::Mul(hn::Mul(y0, width), three), row1 = hn::Mul(hn::Mul(y1, width), three);
  const auto column0 = hn::Mul(x0, three), column1 = hn::Mul(x1, three);
  const V bx = hn::Sub(one, ax), by = hn::Sub(one, ay);
  for (int c = 0; c < 3; ++c) {
    const auto channel = hn::Set(di, c);
    const auto texel = [&](auto row, auto column) {
      return hn::GatherIndex(d, level.rgb, hn::Add(hn::Add(row, column), channel));
    };
    const V c00 = texel(row0, column0), c10 = texel(row0, column1);
    const V c01 = texel(row1, column0), c11 = texel(row1, column1);
    out[c] = hn::Add(hn::Mul(by, hn::Add(hn::Mul(bx, c00), hn::Mul(ax, c10))),
                     hn::Mul(ay, hn::Add(hn::Mul(bx, c01), hn::Mul(ax, c11))));
  }
}

// The integrator's cone() for the lanes of `lanes`: the footprint from the neighbouring pixels'
// rays (a ray differential: the width is the offset between neighbouring origins, the spread
// the angle between neighbouring directions), each ray expanded as RayFrame does it.
template <class D, class DI, class V = hn::Vec<D>, class M>
HWY_INLINE void Cone(D d, DI di, const RayTextures& textures, hn::Vec<DI> pixel, M lanes,
                     V* coneWidth, V* coneSpread) {
  const RayFrame& f = textures.frame();
  const auto* rays = reinterpret_cast<const float*>(&textures.at(0, 0));
  const int w = textures.width(), h = textures.height();
  const auto three = hn::Set(di, 3);
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const V observerY = hn::Set(d, f.observerY), observerZ = hn::Set(d, f.observerZ);
  // o and s − o (expand()); a flat screen has no sag.
  const auto expand = [&](auto index, V* originX, V toScreen[3]) {
    const auto at = hn::Mul(index, three);
    *originX = hn::GatherIndex(d, rays, at);
    const V screenX = hn::GatherIndex(d, rays, hn::Add(at, hn::Set(di, 1)));
    const V screenY = hn::GatherIndex(d, rays, hn::Add(at, hn::Set(di, 2)));
    V sag = zero;
    if (f.curvature != 0.0f) {
      const V k = hn::Set(d, f.curvature);
      const V kxx = hn::Mul(hn::Mul(k, screenX), screenX);
      const V root = hn::Sqrt(hn::Sub(one, hn::Mul(hn::Mul(hn::Mul(k, k), screenX), screenX)));
      sag = hn::Div(kxx, hn::Add(one, root));
    }
    toScreen[0] = hn::Sub(screenX, *originX);
    toScreen[1] = hn::Sub(screenY, observerY);
    toScreen[2] = hn::Sub(sag, observerZ);
  };
  // column and row of the pixel: the quotient in float is exact to the integer below 2^24.
  const auto safe = hn::IfThenElseZero(lanes, pixel);
  const auto row = hn::ConvertTo(
      di, hn::Floor(hn::Div(hn::ConvertTo(d, safe), hn::Set(d, static_cast<float>(w)))));
  const auto column = hn::Sub(safe, hn::Mul(row, hn::Set(di, w)));
  V selfX, self[3];
  expand(safe, &selfX, self);
  const V inverseLength =
      hn::Div(one, hn::Sqrt(Dot3(self[0], self[1], self[2], self[0], self[1], self[2])));
  // The next column or row, or the previous one at the edge; none where there is none.
  const auto neighbour = [&](auto i, int n) {
    const auto next = hn::Add(i, hn::Set(di, 1));
    return hn::IfThenElse(hn::Lt(next, hn::Set(di, n)), next, hn::Sub(i, hn::Set(di, 1)));
  };
  const auto nx = neighbour(column, w), ny = neighbour(row, h);
  const auto indices = {hn::Add(hn::Mul(row, hn::Set(di, w)), nx),
                        hn::Add(hn::Mul(ny, hn::Set(di, w)), column)};
  const auto exists = {hn::Gt(nx, hn::Set(di, -1)), hn::Gt(ny, hn::Set(di, -1))};
  V width = zero, spread = zero;
  auto present = exists.begin();
  for (const auto& index : indices) {
    const auto use = hn::And(lanes, *present++);
    V originX, toScreen[3];
    expand(hn::IfThenElseZero(use, index), &originX, toScreen);
    // Masked rays (NaN origin) are skipped, as cone() skips them.
    const auto counted = hn::And(hn::RebindMask(d, use), hn::Not(hn::IsNaN(originX)));
    V diff[3];
    for (int c = 0; c < 3; ++c) diff[c] = hn::Sub(toScreen[c], self[c]);
    const V across = hn::Abs(hn::Sub(originX, selfX));
    const V angle = hn::Mul(hn::Sqrt(Dot3(diff[0], diff[1], diff[2], diff[0], diff[1], diff[2])),
                            inverseLength);
    width = hn::IfThenElse(counted, StdMax(width, across), width);
    spread = hn::IfThenElse(counted, StdMax(spread, angle), spread);
  }
  // coneWidth held the distance the origin was advanced, which the footprint grows over.
  const auto lanesF = hn::RebindMask(d, lanes);
  *coneWidth = hn::IfThenElse(lanesF, hn::Add(width, hn::Mul(*coneWidth, spread)), *coneWidth);
  *coneSpread = hn::IfThenElse(lanesF, spread, *coneSpread);
}

void LookUpTextures(const TextureLanes& job) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  constexpr size_t kMaxLanes = hn::MaxLanes(decltype(d)());
  const size_t lanes = hn::Lanes(d);  // 1, 4, 8 or 16: a packet's 16 lanes are whole vectors
  const PhysicalMesh& mesh = *job.mesh;
  const TextureImage& image = *job.image;
  const RTCRayHit16& packet = *job.packet;
  const int levels = image.levelCount();
  const auto* triangles = reinterpret_cast<const std::int32_t*>(mesh.triangles.data());
  const float* uvs = mesh.uvs.data()->data();
  const float* faceNormals = mesh.faceNormals.data()->data();
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const auto three = hn::Set(di, 3), two = hn::Set(di, 2);
  const auto mesh32 = hn::Set(di, static_cast<std::int32_t>(job.geomID));
  for (size_t j = 0; j < 16; j += lanes) {
    const auto mineI =
        hn::Eq(hn::LoadU(di, reinterpret_cast<const std::int32_t*>(packet.hit.geomID + j)), mesh32);
    if (hn::AllFalse(di, mineI)) continue;
    const auto mine = hn::RebindMask(d, mineI);
    const auto prim = hn::IfThenElseZero(
        mineI, hn::LoadU(di, reinterpret_cast<const std::int32_t*>(packet.hit.primID + j)));
    if (job.coneUnknown) {
      const auto unknown = hn::And(mineI, hn::Ne(hn::LoadU(di, job.coneUnknown + j), hn::Zero(di)));
      if (!hn::AllFalse(di, unknown)) {
        V width = hn::LoadU(d, job.coneWidth + j), spread = hn::LoadU(d, job.coneSpread + j);
        Cone(d, di, *job.textures, hn::LoadU(di, job.pixel + j), unknown, &width, &spread);
        hn::StoreU(width, d, job.coneWidth + j);
        hn::StoreU(spread, d, job.coneSpread + j);
      }
    }
    // The uv (textureCoordinatesOf): w t0 + u t1 + v t2, and the uv area per physical area.
    const V u = hn::LoadU(d, packet.hit.u + j), v = hn::LoadU(d, packet.hit.v + j);
    const V w = hn::Sub(hn::Sub(one, u), v);
    V corner[3][2];
    const auto prim3 = hn::Mul(prim, three);
    for (int k = 0; k < 3; ++k) {
      const auto vertex =
          hn::Mul(hn::GatherIndex(di, triangles, hn::Add(prim3, hn::Set(di, k))), two);
      corner[k][0] = hn::GatherIndex(d, uvs, vertex);
      corner[k][1] = hn::GatherIndex(d, uvs, hn::Add(vertex, hn::Set(di, 1)));
    }
    V uv[2];
    for (int c = 0; c < 2; ++c) {
      uv[c] = hn::Add(hn::Add(hn::Mul(w, corner[0][c]), hn::Mul(u, corner[1][c])),
                      hn::Mul(v, corner[2][c]));
    }
    V lod = zero;
    if (job.filtering) {
      const V ax = hn::Sub(corner[1][0], corner[0][0]), ay = hn::Sub(corner[1][1], corner[0][1]);
      const V bx = hn::Sub(corner[2][0], corner[0][0]), by = hn::Sub(corner[2][1], corner[0][1]);
      const V uvArea = hn::Abs(hn::Sub(hn::Mul(ax, by), hn::Mul(ay, bx)));
      const V texelsPerMetreSq =
          hn::Div(uvArea, hn::GatherIndex(d, mesh.crossLengths.data(), prim));
      // The ray cone: footprint width at the hit, stretched by the incidence angle, in texels.
      const V t = hn::LoadU(d, packet.ray.tfar + j);
      const V width =
          hn::Add(hn::LoadU(d, job.coneWidth + j), hn::Mul(t, hn::LoadU(d, job.coneSpread + j)));
      V normal[3];
      for (int c = 0; c < 3; ++c)
        normal[c] = hn::GatherIndex(d, faceNormals, hn::Add(prim3, hn::Set(di, c)));
      const V dx = hn::LoadU(d, packet.ray.dir_x + j), dy = hn::LoadU(d, packet.ray.dir_y + j),
              dz = hn::LoadU(d, packet.ray.dir_z + j);
      const V cosine =
          StdMax(hn::Abs(Dot3(dx, dy, dz, normal[0], normal[1], normal[2])), hn::Set(d, 0.05f));
      const V texelsPerMetre =
          hn::Sqrt(hn::Mul(hn::Mul(texelsPerMetreSq, hn::Set(d, static_cast<float>(image.width()))),
                           hn::Set(d, static_cast<float>(image.height()))));
      const V footprint =
          StdMax(hn::Div(hn::Mul(width, texelsPerMetre), cosine), hn::Set(d, 1e-30f));
      // std::log2 itself: a vector logarithm differs from it in the last bits.
      HWY_ALIGN float value[kMaxLanes];
      HWY_ALIGN std::int32_t use[kMaxLanes];
      hn::Store(footprint, d, value);
      hn::Store(hn::VecFromMask(di, mineI), di, use);
      for (size_t lane = 0; lane < lanes; ++lane)
        value[lane] = use[lane] ? std::log2(value[lane]) : 0.0f;
      lod = hn::Load(d, value);
    }
    // TextureImage::lookup: the level clamped to the pyramid, its whole part and fraction.
    const auto finite = hn::And(mine, hn::And(hn::IsFinite(uv[0]), hn::IsFinite(uv[1])));
    const auto finiteI = hn::RebindMask(di, finite);
    const V maxLevel = hn::Set(d, static_cast<float>(levels - 1));
    const V clamped = hn::IfThenElse(hn::Lt(lod, zero), zero,
                                     hn::IfThenElse(hn::Lt(maxLevel, lod), maxLevel, lod));
    const V level = hn::IfThenElseZero(hn::IsFinite(lod), clamped);
    const auto l0 = hn::ConvertTo(di, level);
    const V a = hn::Sub(level, hn::ConvertTo(d, l0));
    const auto l1 = hn::Add(l0, hn::Set(di, 1));
    const auto blend = hn::And(
        finiteI, hn::And(hn::RebindMask(di, hn::Gt(a, zero)), hn::Lt(l1, hn::Set(di, levels))));
    V first[3] = {zero, zero, zero}, second[3] = {zero, zero, zero};
    for (int l = 0; l < levels; ++l) {
      const auto atFirst = hn::And(finiteI, hn::Eq(l0, hn::Set(di, l)));
      const auto atSecond = hn::And(blend, hn::Eq(l1, hn::Set(di, l)));
      const auto here = hn::Or(atFirst, atSecond);
      if (hn::AllFalse(di, here)) continue;
      // Non-finite lanes read at uv 0 (their colour comes from the scalar lookup below).
      V colour[3];
      Bilinear(d, di, image.level(l), hn::IfThenElseZero(finite, uv[0]),
               hn::IfThenElseZero(finite, uv[1]), here, colour);
      for (int c = 0; c < 3; ++c) {
        first[c] = hn::IfThenElse(hn::RebindMask(d, atFirst), colour[c], first[c]);
        second[c] = hn::IfThenElse(hn::RebindMask(d, atSecond), colour[c], second[c]);
      }
    }
    const auto blendF = hn::RebindMask(d, blend);
    const V keep = hn::Sub(one, a);
    for (int c = 0; c < 3; ++c) {
      const V mixed = hn::Add(hn::Mul(keep, first[c]), hn::Mul(a, second[c]));
      hn::StoreU(hn::IfThenElse(blendF, mixed, first[c]), d, job.color[c] + j);
    }
    if (!hn::AllFalse(d, hn::AndNot(finite, mine))) {
      // A uv that is not finite (a degenerate triangle's): what lookup gives it.
      HWY_ALIGN float uvOf[2][kMaxLanes], lodOf[kMaxLanes];
      HWY_ALIGN std::int32_t odd[kMaxLanes];
      hn::Store(uv[0], d, uvOf[0]);
      hn::Store(uv[1], d, uvOf[1]);
      hn::Store(lod, d, lodOf);
      hn::Store(hn::VecFromMask(di, hn::AndNot(finiteI, mineI)), di, odd);
      for (size_t lane = 0; lane < lanes; ++lane) {
        if (!odd[lane]) continue;
        const Rgb colour = image.lookup(uvOf[0][lane], uvOf[1][lane], lodOf[lane]);
        for (int c = 0; c < 3; ++c) job.color[c][j + lane] = colour[c];
      }
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace parallax {

HWY_EXPORT(LookUpTextures);

void lookUpTextures(const TextureLanes& job) { HWY_DYNAMIC_DISPATCH(LookUpTextures)(job); }

}  // namespace parallax
#endif
