// The scalar integrator's small vector formulas, lane-wise for Highway kernels (included once
// per target, inside each kernel's HWY_NAMESPACE; no include guard of the usual kind). Each
// evaluates in the order Eigen does for a Vector3f, so a kernel's results are bit-identical to
// the scalar code's: Eigen sums three terms as e0 + (e1 + e2) (its reduction splits in halves),
// and std::max(a, b) is (a < b ? b : a). No MulAdd: a fused multiply-add rounds once, not twice.

#if defined(PARALLAX_TRACER_SIMD_MATH_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef PARALLAX_TRACER_SIMD_MATH_INL_H_
#undef PARALLAX_TRACER_SIMD_MATH_INL_H_
#else
#define PARALLAX_TRACER_SIMD_MATH_INL_H_
#endif

#include <hwy/highway.h>

#include <Eigen/Core>
#include <cmath>

HWY_BEFORE_NAMESPACE();
namespace parallax {
namespace HWY_NAMESPACE {

// a · b of Eigen::Vector3f.
template <class V>
HWY_INLINE V Dot3(V ax, V ay, V az, V bx, V by, V bz) {
  namespace hn = hwy::HWY_NAMESPACE;
  return hn::Add(hn::Mul(ax, bx), hn::Add(hn::Mul(ay, by), hn::Mul(az, bz)));
}

// std::max(a, b) with its NaN behaviour (a when the comparison fails).
template <class V>
HWY_INLINE V StdMax(V a, V b) {
  namespace hn = hwy::HWY_NAMESPACE;
  return hn::IfThenElse(hn::Lt(a, b), b, a);
}

// Eigen's maxCoeff() of (r, g, b).
template <class V>
HWY_INLINE V MaxCoeff3(V r, V g, V b) {
  return StdMax(r, StdMax(g, b));
}

// offsetRayOrigin (ray_batch.h) of one coordinate: p moved 256·n ulps along the normal, or by
// n/65536 near the origin (where ulps are too small).
template <class D, class V>
HWY_INLINE V OffsetCoordinate(D d, V p, V n) {
  namespace hn = hwy::HWY_NAMESPACE;
  const hn::RebindToSigned<D> di;
  const auto steps = hn::ConvertTo(di, hn::Mul(hn::Set(d, 256.0f), n));  // truncates, as the cast
  const auto negative = hn::RebindMask(di, hn::Lt(p, hn::Zero(d)));
  const V moved =
      hn::BitCast(d, hn::Add(hn::BitCast(di, p), hn::IfThenElse(negative, hn::Neg(steps), steps)));
  const V near = hn::Add(p, hn::Mul(hn::Set(d, 1.0f / 65536.0f), n));
  return hn::IfThenElse(hn::Lt(hn::Abs(p), hn::Set(d, 1.0f / 32.0f)), near, moved);
}

// Lanes whose ray (from a along the unit l, for t in [0, tfar]) may meet `sphere`: false only
// where it certainly passes it. The squared distance of the centre from the ray's line, |w|² −
// (w · l)², loses a few ulps of |w|² to cancellation and to |l| being 1 only to a few ulps: the
// allowance of 1e-5 |w|² covers both. NaN compares false: may meet.
template <class D, class V = hwy::HWY_NAMESPACE::Vec<D>>
HWY_INLINE auto MayMeetSphere(D d, V ax, V ay, V az, V lx, V ly, V lz, V tfar,
                              const Eigen::Vector4f& sphere) {
  namespace hn = hwy::HWY_NAMESPACE;
  const V wx = hn::Sub(hn::Set(d, sphere.x()), ax);
  const V wy = hn::Sub(hn::Set(d, sphere.y()), ay);
  const V wz = hn::Sub(hn::Set(d, sphere.z()), az);
  const V along = Dot3(wx, wy, wz, lx, ly, lz);
  const V square = Dot3(wx, wy, wz, wx, wy, wz);
  const V radius = hn::Set(d, sphere.w());
  const V off = hn::Sub(square, hn::Mul(along, along));
  const auto passesBeside =
      hn::Gt(off, hn::Add(hn::Mul(radius, radius), hn::Mul(hn::Set(d, 1e-5f), square)));
  const auto behind = hn::Lt(hn::Add(along, radius), hn::Zero(d));
  const auto beyond = hn::Gt(hn::Sub(along, radius), hn::Mul(tfar, hn::Set(d, 1.0f + 1e-5f)));
  return hn::Not(hn::Or(passesBeside, hn::Or(behind, beyond)));
}

// Lanes whose ray (from a along the unit l, to an infinite tfar) certainly passes through
// `sphere`: its closest approach to the centre lies ahead of a, nearer than the radius by more
// than the rounding of |w − (w · l) l|² (a few ulps of |w|², with |l| 1 to a few ulps).
template <class D, class V = hwy::HWY_NAMESPACE::Vec<D>>
HWY_INLINE auto PassesThroughSphere(D d, V ax, V ay, V az, V lx, V ly, V lz,
                                    const Eigen::Vector4f& sphere) {
  namespace hn = hwy::HWY_NAMESPACE;
  const V wx = hn::Sub(hn::Set(d, sphere.x()), ax);
  const V wy = hn::Sub(hn::Set(d, sphere.y()), ay);
  const V wz = hn::Sub(hn::Set(d, sphere.z()), az);
  const V along = Dot3(wx, wy, wz, lx, ly, lz);
  const V square = Dot3(wx, wy, wz, wx, wy, wz);
  const V ox = hn::Sub(wx, hn::Mul(along, lx));
  const V oy = hn::Sub(wy, hn::Mul(along, ly));
  const V oz = hn::Sub(wz, hn::Mul(along, lz));
  const V off = Dot3(ox, oy, oz, ox, oy, oz);
  const V radius = hn::Set(d, sphere.w());
  const auto inside =
      hn::Lt(hn::Add(off, hn::Mul(hn::Set(d, 1e-5f), square)), hn::Mul(radius, radius));
  return hn::And(inside, hn::Gt(along, hn::Zero(d)));
}

// Lanes whose ray (from a along the unit l, for t in [0, tfar]) certainly misses `ring`
// (PhysicalMesh::Ring): it never enters the ring's slab, or crosses it only nearer the axis than
// `inner`, or only farther than `outer`. The distance from the axis squared is a quadratic in t:
// its largest value on the slab's interval is at an end, its smallest at an end or its vertex.
// Every test is a comparison that NaN makes false (may meet); the ring is padded far beyond the
// rounding (physical_scene.cpp).
template <class D, class V = hwy::HWY_NAMESPACE::Vec<D>>
HWY_INLINE auto MissesRing(D d, V ax, V ay, V az, V lx, V ly, V lz, V tfar,
                           const Eigen::Vector3f& centre, const Eigen::Vector3f& axis, float inner,
                           float outer, float halfHeight) {
  namespace hn = hwy::HWY_NAMESPACE;
  const V nx = hn::Set(d, axis.x()), ny = hn::Set(d, axis.y()), nz = hn::Set(d, axis.z());
  const V wx = hn::Sub(ax, hn::Set(d, centre.x()));
  const V wy = hn::Sub(ay, hn::Set(d, centre.y()));
  const V wz = hn::Sub(az, hn::Set(d, centre.z()));
  const V h0 = Dot3(nx, ny, nz, wx, wy, wz);
  const V hl = Dot3(nx, ny, nz, lx, ly, lz);
  const V height = hn::Set(d, halfHeight);
  // The slab's interval [t1, t2] within [0, tfar] (±∞ where the ray runs along the plane).
  const V ta = hn::Div(hn::Sub(hn::Neg(height), h0), hl);
  const V tb = hn::Div(hn::Sub(height, h0), hl);
  const V t1 = hn::Max(hn::Min(ta, tb), hn::Zero(d));
  const V t2 = hn::Min(hn::Max(ta, tb), tfar);
  const auto slabMissed = hn::Gt(t1, t2);
  // Across the axis: q(t) = q0 + t ql.
  const V q0x = hn::Sub(wx, hn::Mul(h0, nx)), q0y = hn::Sub(wy, hn::Mul(h0, ny)),
          q0z = hn::Sub(wz, hn::Mul(h0, nz));
  const V qlx = hn::Sub(lx, hn::Mul(hl, nx)), qly = hn::Sub(ly, hn::Mul(hl, ny)),
          qlz = hn::Sub(lz, hn::Mul(hl, nz));
  const V a = Dot3(qlx, qly, qlz, qlx, qly, qlz);
  const V b = Dot3(q0x, q0y, q0z, qlx, qly, qlz);
  const V c = Dot3(q0x, q0y, q0z, q0x, q0y, q0z);
  const auto squared = [&](V t) {
    return hn::Add(c, hn::Mul(t, hn::Add(hn::Add(b, b), hn::Mul(a, t))));
  };
  const V at1 = squared(t1), at2 = squared(t2);
  const V vertex = hn::Max(t1, hn::Min(t2, hn::Div(hn::Neg(b), a)));
  const V atVertex = squared(vertex);
  const V inner2 = hn::Set(d, inner * inner), outer2 = hn::Set(d, outer * outer);
  const auto inHole = hn::And(hn::Lt(at1, inner2), hn::Lt(at2, inner2));
  const auto beyond =
      hn::And(hn::And(hn::Gt(at1, outer2), hn::Gt(at2, outer2)), hn::Gt(atVertex, outer2));
  return hn::Or(slabMissed, hn::Or(inHole, beyond));
}

// n · a − c of the plane n · x = c (`plane`: n, c): a's signed distance from it.
template <class D, class V = hwy::HWY_NAMESPACE::Vec<D>>
HWY_INLINE V PlaneDistance(D d, V ax, V ay, V az, const Eigen::Vector4f& plane) {
  namespace hn = hwy::HWY_NAMESPACE;
  return hn::Sub(
      Dot3(hn::Set(d, plane.x()), hn::Set(d, plane.y()), hn::Set(d, plane.z()), ax, ay, az),
      hn::Set(d, plane.w()));
}

// Lanes whose ray (from a along the unit l, for t in [0, tfar]) may cross the plane n · x = c:
// false only where both its ends lie on one side, farther than `margin`. A ray along the plane
// to an infinite tfar gives 0 · ∞, NaN, which compares false: may cross.
template <class D, class V = hwy::HWY_NAMESPACE::Vec<D>>
HWY_INLINE auto MayCrossPlane(D d, V ax, V ay, V az, V lx, V ly, V lz, V tfar,
                              const Eigen::Vector4f& plane, float margin) {
  namespace hn = hwy::HWY_NAMESPACE;
  const V start = PlaneDistance(d, ax, ay, az, plane);
  const V along =
      Dot3(hn::Set(d, plane.x()), hn::Set(d, plane.y()), hn::Set(d, plane.z()), lx, ly, lz);
  const V end = hn::Add(start, hn::Mul(along, tfar));
  const V above = hn::Set(d, margin), below = hn::Set(d, -margin);
  const auto over = hn::And(hn::Gt(start, above), hn::Gt(end, above));
  const auto under = hn::And(hn::Lt(start, below), hn::Lt(end, below));
  return hn::Not(hn::Or(over, under));
}

// The lanes of `v` that `keep` selects, written in order from `to` on, followed by whatever
// fills the rest of the vector (the destination has room for a whole vector). Compressing in a
// register and storing the whole vector: AVX-512's compress-to-memory, which Highway's
// CompressStore uses, took a third of the shadow-ray kernel's time in the profile.
template <class D, class V, class M>
HWY_INLINE void CompressAppend(D d, V v, M keep, hwy::HWY_NAMESPACE::TFromD<D>* to) {
  namespace hn = hwy::HWY_NAMESPACE;
  hn::StoreU(hn::Compress(v, keep), d, to);
}

// The Phong highlight's x^e for x in [0, 1], in the lanes of `active`: whole exponents up to 256
// (every fixture's) by repeated squaring, a few ulps from std::pow and several times cheaper;
// any other exponent through std::pow, one lane at a time.
template <class D, class V = hwy::HWY_NAMESPACE::Vec<D>, class M>
HWY_INLINE V PhongPower(D d, V x, V e, M active) {
  namespace hn = hwy::HWY_NAMESPACE;
  const hn::RebindToSigned<D> di;
  const auto whole = hn::ConvertTo(di, e);  // truncates, as static_cast<int> does
  const auto isWhole = hn::And(
      hn::Eq(hn::ConvertTo(d, whole), e),
      hn::RebindMask(d, hn::And(hn::Gt(whole, hn::Zero(di)), hn::Lt(whole, hn::Set(di, 257)))));
  V result = hn::Set(d, 1.0f);
  V square = x;
  const auto one = hn::Set(di, 1);
  for (int bit = 0; bit < 9; ++bit) {
    const auto set = hn::RebindMask(d, hn::Eq(hn::And(hn::ShiftRightSame(whole, bit), one), one));
    result = hn::IfThenElse(set, hn::Mul(result, square), result);
    square = hn::Mul(square, square);
  }
  const auto other = hn::AndNot(isWhole, active);
  if (!hn::AllFalse(d, other)) {
    constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(float);
    HWY_ALIGN float xs[kMaxLanes], es[kMaxLanes], rs[kMaxLanes];
    hn::Store(x, d, xs);
    hn::Store(e, d, es);
    hn::Store(result, d, rs);
    HWY_ALIGN std::int32_t mask[kMaxLanes];
    hn::Store(hn::VecFromMask(di, hn::RebindMask(di, other)), di, mask);
    for (size_t i = 0; i < hn::Lanes(d); ++i)
      if (mask[i]) rs[i] = std::pow(xs[i], es[i]);
    result = hn::Load(d, rs);
  }
  return result;
}

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#endif  // PARALLAX_TRACER_SIMD_MATH_INL_H_
