// Compiled once per instruction set by Highway's foreach_target, as shadow_ray_kernel.cpp is.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3  // SSSE3 without SSE4 (CPUs before 2008): one compile less
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tracer/primary_ray_kernel.cpp"
#include "tracer/primary_ray_kernel.h"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cstring>
#include <limits>

#include "tracer/simd_math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace parallax {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

PrimaryRayCounts MakePrimaryRays(const PrimaryRayRow& row, StagedRays* staged) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(float);
  const size_t lanes = hn::Lanes(d);

  const V zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const V infinity = hn::Set(d, std::numeric_limits<float>::infinity());
  const V observerY = hn::Set(d, row.frame.observerY), observerZ = hn::Set(d, row.frame.observerZ);
  const V curvature = hn::Set(d, row.frame.curvature);
  const bool flat = row.frame.curvature == 0.0f;
  const V lo[3] = {hn::Set(d, row.boundsMin.x()), hn::Set(d, row.boundsMin.y()),
                   hn::Set(d, row.boundsMin.z())};
  const V hi[3] = {hn::Set(d, row.boundsMax.x()), hn::Set(d, row.boundsMax.y()),
                   hn::Set(d, row.boundsMax.z())};
  const V boxMargin = hn::Set(d, row.boxMargin);
  const V backgroundR = hn::Set(d, row.background.x());
  const V backgroundG = hn::Set(d, row.background.y());
  const V backgroundB = hn::Set(d, row.background.z());

  float* const field[] = {staged->field(StagedRays::kOx), staged->field(StagedRays::kOy),
                          staged->field(StagedRays::kOz), staged->field(StagedRays::kDx),
                          staged->field(StagedRays::kDy), staged->field(StagedRays::kDz),
                          staged->field(StagedRays::kR)};
  auto* const pixels = reinterpret_cast<float*>(staged->pixels());
  size_t kept = staged->size();
  PrimaryRayCounts counts;
  const auto* texture = reinterpret_cast<const float*>(row.rays);
  auto* out = reinterpret_cast<float*>(row.out);
  const size_t count = static_cast<size_t>(row.count);

  for (size_t j = 0; j < count; j += lanes) {
    const size_t here = count - j < lanes ? count - j : lanes;
    V originX, screenX, screenY;
    if (here == lanes) {
      hn::LoadInterleaved3(d, texture + 3 * j, originX, screenX, screenY);
    } else {
      // The row's last pixels: a full vector's worth, the missing ones masked (NaN).
      HWY_ALIGN float tail[3 * kMaxLanes];
      for (float& v : tail) v = std::numeric_limits<float>::quiet_NaN();
      std::memcpy(tail, texture + 3 * j, 3 * here * sizeof(float));
      hn::LoadInterleaved3(d, tail, originX, screenX, screenY);
    }
    const auto valid = hn::FirstN(d, here);
    const auto masked = hn::IsNaN(originX);
    if (here == lanes && hn::AllTrue(d, masked)) {
      // Pixels no ray leaves (half of a module's, in runs along its rows): black, no arithmetic.
      counts.masked += static_cast<long>(lanes);
      hn::StoreInterleaved3(zero, zero, zero, d, out + 3 * j);
      continue;
    }

    // o and s − o; a flat screen has no sag.
    const V toX = hn::Sub(screenX, originX), toY = hn::Sub(screenY, observerY);
    V sag = zero;
    if (!flat) {
      const V kx = hn::Mul(curvature, screenX);
      const V k2x2 = hn::Mul(hn::Mul(hn::Mul(curvature, curvature), screenX), screenX);
      sag = hn::Div(hn::Mul(kx, screenX), hn::Add(one, hn::Sqrt(hn::Sub(one, k2x2))));
    }
    const V toZ = hn::Sub(sag, observerZ);

    // Slab test, all three axes (the scalar loop stops at the first empty interval; t0 only
    // grows and t1 only shrinks, so a lane that failed stays failed).
    const V origin[3] = {originX, observerY, observerZ};
    const V to[3] = {toX, toY, toZ};
    V t0 = zero, t1 = infinity;
    for (int axis = 0; axis < 3; ++axis) {
      const V inverse = hn::Div(one, to[axis]);
      const V a = hn::Mul(hn::Sub(lo[axis], origin[axis]), inverse);
      const V b = hn::Mul(hn::Sub(hi[axis], origin[axis]), inverse);
      const auto swap = hn::Gt(a, b);
      const V near = hn::IfThenElse(swap, b, a), far = hn::IfThenElse(swap, a, b);
      // NaN from 0·inf (a ray in the slab's plane) leaves the interval unchanged.
      t0 = hn::IfThenElse(hn::Gt(near, t0), near, t0);
      t1 = hn::IfThenElse(hn::Lt(far, t1), far, t1);
    }
    const auto inBox = hn::Not(hn::Gt(t0, t1));
    const auto traced = hn::And(valid, hn::AndNot(masked, inBox));
    const auto missed = hn::And(valid, hn::AndNot(masked, hn::Not(inBox)));
    counts.masked += static_cast<long>(hn::CountTrue(d, hn::And(valid, masked)));
    counts.missedBounds += static_cast<long>(hn::CountTrue(d, missed));

    // Every pixel of the row is written (the frame is reused from frame to frame).
    const V red = hn::IfThenElseZero(missed, backgroundR);
    const V green = hn::IfThenElseZero(missed, backgroundG);
    const V blue = hn::IfThenElseZero(missed, backgroundB);
    if (here == lanes) {
      hn::StoreInterleaved3(red, green, blue, d, out + 3 * j);
    } else {
      HWY_ALIGN float tail[3 * kMaxLanes];
      hn::StoreInterleaved3(red, green, blue, d, tail);
      std::memcpy(out + 3 * j, tail, 3 * here * sizeof(float));
    }
    if (hn::AllFalse(d, traced)) continue;

    // The ray starts just before the box (whitted_integrator.cpp, initialRays, says why); one
    // square root and one division for the three uses of the length.
    const V length = hn::Sqrt(Dot3(toX, toY, toZ, toX, toY, toZ));
    const V inverseLength = hn::Div(one, length);
    const V advance = StdMax(zero, hn::Sub(t0, hn::Mul(boxMargin, inverseLength)));
    const V values[] = {hn::Add(originX, hn::Mul(advance, toX)),
                        hn::Add(observerY, hn::Mul(advance, toY)),
                        hn::Add(observerZ, hn::Mul(advance, toZ)),
                        hn::Mul(toX, inverseLength),
                        hn::Mul(toY, inverseLength),
                        hn::Mul(toZ, inverseLength),
                        hn::Mul(advance, length)};
    for (size_t f = 0; f < sizeof(values) / sizeof(values[0]); ++f)
      CompressAppend(d, values[f], traced, field[f] + kept);
    const auto pixel = hn::Add(hn::Iota(di, 0), hn::Set(di, row.firstPixel + static_cast<int>(j)));
    CompressAppend(d, hn::BitCast(d, pixel), traced, pixels + kept);
    kept += hn::CountTrue(d, traced);
  }
  staged->setSize(kept);
  return counts;
}

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace parallax {

HWY_EXPORT(MakePrimaryRays);

PrimaryRayCounts makePrimaryRays(const PrimaryRayRow& row, StagedRays* staged) {
  return HWY_DYNAMIC_DISPATCH(MakePrimaryRays)(row, staged);
}

}  // namespace parallax
#endif
